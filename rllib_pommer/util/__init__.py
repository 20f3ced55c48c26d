"""Standard-library plumbing any layer may use: work streamed over processes (`parallel`),
where the shipped policies and curricula are (`shipped`), output paths checked before the
work (`outputs`), command-line options generated from settings dataclasses (`cli_options`),
the one rule for the types of our TOML files' values (`toml_values`) and other libraries'
exceptions in one line (`errors`). Nothing here imports numpy
or the rest of the project."""
