"""eval: builds on dresspack_gym (see README)."""
