"""Reward terms as pure functions `fn(env, **params) -> (num_envs, num_agents)`, and the manager that weighs them."""
