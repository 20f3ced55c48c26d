"""The RLlib pieces of PPO: the multi-agent env (`env`), the trained module and its learner
(`rl_module`, `learner`, `trained_agents`), the fixed modules of teammates and opponents
(`fixed_modules`, `search_module`), the league (`league`), the filters as connectors
(`connectors`), the callbacks (`stages`, `outcomes`, `league.LeagueCallback`) and the PPOConfig
of a curriculum built from plain data (`config`)."""
