"""Standard-library plumbing any layer may use: work streamed over processes (`parallel`),
where the shipped policies and curricula are (`shipped`), output paths checked before the
work (`outputs`) and command-line options generated from settings dataclasses
(`cli_options`). Nothing here imports numpy or the rest of the project."""
