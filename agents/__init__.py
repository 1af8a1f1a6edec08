"""agents: builds on dresspack_gym (see README)."""
