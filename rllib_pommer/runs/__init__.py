"""Saved runs read back, without Ray: a run's history and its legs (`history`), its checkpoints
found, checked and played as a policy kind (`checkpoints`), and its learner exported as a shipped
policy (`export`)."""
