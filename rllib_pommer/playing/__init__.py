"""A person plays a seat of a Team game in the browser, against and beside named policies.

`session.HumanGame` is the game (engine, the other seats' agents from the arena's registry, the
replay being recorded); `server` is the web side (the page, its moves, the turn clock, the page
holding the seat); `python -m rllib_pommer.play` is the command. Nothing here imports Ray, and torch
only comes in when a seat is given a learned policy (the registry imports that kind when named).
"""
