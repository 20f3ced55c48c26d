"""Pictures of games and runs: Pillow frames and GIFs, an offline HTML viewer, the paper's figures.

Nothing here imports rl/ or training: it reads game and arena records, and draws a run's training
from the figures `runs/history.py` computes from the run's history and the job hands over.
"""
