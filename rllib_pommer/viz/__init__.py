"""Pictures of games and runs: Pillow frames and GIFs, an offline HTML viewer, the paper's figures.

Nothing here is imported by the game, the agents or training; it only reads what they write
(game records, arena records, Tune trial directories).
"""
