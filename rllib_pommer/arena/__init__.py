"""Matches between named policies: the games, played in worker processes (`match`), what each
did and the match's summary (`records`), and the interval rule the summary and the report
share (`rates`)."""
