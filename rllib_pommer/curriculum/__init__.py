"""A training schedule as data, without Ray or torch: the run's settings (`settings`), the names
a run shares with its files and envs (`names`), curriculum files checked on load and the one a run
trains on (`curriculum`), the seat mapping of a stage (`mapping`) and prioritized matchmaking's
rule (`matchmaking`)."""
