"""Our policies behind the NeurIPS-2018 Pommerman competition's HTTP agent protocol.

In the competition every agent was a Docker container running an HTTP server (port 10080) that a
runner drove: `GET /ping`, `POST /init_agent` (seat and game type), `POST /action` (one observation,
answered with an action 0..5 within the runner's 0.15 s), `POST /episode_end` and `POST /shutdown`.
The 2019 competition played TeamRadio the same way (game type 3): each observation also carries
`message`, the teammate's last two words 0..7, and an agent answers `[move, word, word]`; we serve
both games. Serving our policies the same way lets them play the competition's tooling and other
teams' containers; `rllib_pommer.agents.http_agent` is the other side, so our arena can play such
containers.

Our one extension: `/init_agent` accepts an optional `seed` (see `protocol.rng_from_seed`), so a
served match replays the in-process one exactly. Other callers never send it and lose nothing.
"""
