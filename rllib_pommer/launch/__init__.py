"""A run's life on Tune and Ray: start, and resume from the run's data (`training`), its Tune
callbacks (`tune_callbacks`), stop at a checkpoint and pack (`packing`), the run's own Ray
instance (`ray_session`), Ray's start-up noise dropped (`quiet`), and the PPO loop's speeds for
`bench` (`speed`)."""
