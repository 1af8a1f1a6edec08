"""One episode of a trained masked policy in its env, as select-model and self-imitate roll it out."""

from __future__ import annotations

# what rolled-out data (counterfactual labels, self-imitation rollouts) depends on besides its settings: the
# simulation and its configs, the training code that rolls the policy out, the agents' code that chooses its actions
# (the policy's masks, ppo-search's ranked rule) and the shipped policies (a folder of other code is not resumed)
ROLLOUT_CODE = ("dresspack_gym", "dresspack_gym.configs", "dresspack.training", "dresspack.agents")


def roll_out(env, model, episode_seed: int, deterministic: bool, record: bool = False):
    """Reset ``env`` with ``episode_seed`` and act until the episode ends (the most probable allowed action, or one
    sampled with torch's generator as the caller seeded it). Returns (return, ∫C dt, last info, steps), where steps
    are the (observation, masks, action) of each step if ``record``, else empty."""
    obs, _ = env.reset(seed=episode_seed)
    total, wear, done, steps = 0.0, 0.0, False, []
    while not done:
        masks = env.action_masks()
        action, _ = model.predict(obs, action_masks=masks, deterministic=deterministic)
        if record:
            steps.append((obs, masks, int(action)))
        obs, reward, terminated, truncated, info = env.step(int(action))
        total, wear, done = total + reward, wear + info["integral_cost"], terminated or truncated
    return total, wear, info, steps
