"""PPO on RLlib: the multi-agent env, the learner and fixed modules, curriculum, filters, CLI."""
