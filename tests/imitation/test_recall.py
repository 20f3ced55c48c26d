"""The memory planes (imitation/recall.py): what an agent saw under today's fog, from its own
observations alone, checked against a plain restatement of the rule over whole seeded games; and
the 22-plane networks they feed (widened weights play exactly as the 19-plane ones)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rllib_pommer.agents.belief import new_memory
from rllib_pommer.agents.registry import Acting, make_agent
from rllib_pommer.game.constants import TEAM_PRESET, Item
from rllib_pommer.game.engine import Game
from rllib_pommer.imitation.features import DESIRABILITY, NUM_PLANES, featurize
from rllib_pommer.imitation.learned import LearnedPolicy, load_policy_net
from rllib_pommer.imitation.network import PommerNet, build_net, load_weights, planes_of
from rllib_pommer.imitation.recall import MEMORY_PLANES, RECALL_STEPS, recall_planes

FOG, FLAMES, BOMB, PASSAGE = int(Item.FOG), int(Item.FLAMES), int(Item.BOMB), int(Item.PASSAGE)
ENEMIES = {0: (1, 3), 1: (0, 2), 2: (1, 3), 3: (0, 2)}  # Team: 0 and 2 against 1 and 3
CORNERS = {0: (1, 1), 1: (9, 1), 2: (9, 9), 3: (1, 9)}


class SlowMemory:
    """The rule of recall.py's docstring, restated with dicts, for one agent."""

    def __init__(self, me: int):
        self.me = me
        self.cells: dict[tuple[int, int], tuple] = {}  # cell -> (step, code, life, moving, flame)
        self.agents = {a: (CORNERS[a], 0) for a in range(4)}  # agent -> (cell, step seen)

    def planes(self, obs) -> np.ndarray:
        step = int(obs.step_count)
        for (r, c), code in np.ndenumerate(obs.board):
            if code == FOG:
                continue
            if code >= int(Item.AGENT0):
                self.agents[int(code) - int(Item.AGENT0)] = ((r, c), step)
            stored = PASSAGE if code >= int(Item.AGENT0) or code == BOMB else int(code)
            self.cells[(r, c)] = (step, stored, int(obs.bomb_life[r, c]),
                                  int(obs.bomb_moving_direction[r, c]), int(obs.flame_life[r, c]))
        out = np.zeros((3, 11, 11), np.float32)
        for (r, c), (seen, code, life, moving, flame) in self.cells.items():
            if obs.board[r, c] != FOG:
                continue
            age = step - seen
            if code == FLAMES and flame - age <= 0:
                code = PASSAGE
            out[2, r, c] = (DESIRABILITY[code] + 1) / 9
            if life - age > 0 and moving == 0:
                out[1, r, c] = (life - age) / 10
        for enemy in ENEMIES[self.me]:
            (r, c), seen = self.agents[enemy]
            age = step - seen
            if obs.alive[enemy] and obs.board[r, c] == FOG and age <= RECALL_STEPS:
                out[0, r, c] = max(out[0, r, c], 1 - age / (RECALL_STEPS + 1))
        return out


@pytest.mark.parametrize("seed", [3, 11])
def test_the_memory_planes_follow_the_rule_over_seeded_games(seed):
    game = Game(TEAM_PRESET)
    obs = game.reset(seed)
    agents = [make_agent("simple") for _ in range(4)]
    for a, agent in enumerate(agents):
        agent.reset(a, int(obs.game_type[a]), np.random.default_rng(seed * 4 + a))
    memory, slow = new_memory(4), [SlowMemory(a) for a in range(4)]
    seen_out_of_view = bombs_remembered = 0
    done = False
    while not done:
        planes = recall_planes(obs, memory)
        for a in range(4):
            expected = slow[a].planes(obs.select(a))
            np.testing.assert_allclose(planes[a], expected, atol=1e-6,
                                       err_msg=f"seed {seed} step {obs.step_count[a]} agent {a}")
            assert not planes[a][:, obs.board[a] != FOG].any()  # nothing on cells in view
        seen_out_of_view += int((planes[:, 0] > 0).sum())
        bombs_remembered += int((planes[:, 1] > 0).sum())
        actions = np.array([agent.act(obs.select(a)) for a, agent in enumerate(agents)])
        obs, _, done, _ = game.step(actions)
    assert seen_out_of_view > 0 and bombs_remembered > 0  # the game exercised both planes


def test_a_game_starts_with_the_enemies_remembered_in_their_corners():
    obs = Game(TEAM_PRESET).reset(5)
    planes = recall_planes(obs, new_memory(4))
    for a in range(4):
        assert planes[a, 0].sum() == 2.0  # both enemies, out of view, seen at step 0
        for enemy in ENEMIES[a]:
            assert planes[a, 0][CORNERS[enemy]] == 1.0


def test_memory_rows_that_do_not_fit_are_refused():
    obs = Game(TEAM_PRESET).reset(0)
    with pytest.raises(ValueError, match=r"memory rows \(3, \d+\) int64 do not fit 4"):
        recall_planes(obs, new_memory(3))


def test_widened_weights_play_as_the_19_plane_net(tmp_path):
    torch.manual_seed(0)
    narrow = PommerNet()
    path = tmp_path / "pi.pt"
    torch.save(narrow.state_dict(), path)
    wide = load_policy_net(path, planes=MEMORY_PLANES)
    assert wide.planes == MEMORY_PLANES and planes_of(wide.state_dict()) == MEMORY_PLANES
    planes = torch.rand(8, MEMORY_PLANES, 11, 11)
    with torch.no_grad():  # the memory planes start unheard
        torch.testing.assert_close(wide(planes), narrow(planes[:, :NUM_PLANES]), rtol=0, atol=0)
        torch.testing.assert_close(narrow(planes), narrow(planes[:, :NUM_PLANES]))  # first 19
    with pytest.raises(ValueError, match="reads 22 input planes .* given 19"):
        wide(planes[:, :NUM_PLANES])
    torch.save(wide.state_dict(), path)
    assert load_policy_net(path).planes == MEMORY_PLANES  # read from the weights
    with pytest.raises(ValueError, match="weights read 22 input planes, more than .* 19"):
        load_weights(build_net(), wide.state_dict())


def test_a_policy_with_memory_needs_its_agents_memory(tmp_path):
    policy = LearnedPolicy(build_net(planes=MEMORY_PLANES), tmp_path / "pi.pt",
                           Acting(greedy=True, temperature=1.0))
    obs = Game(TEAM_PRESET).reset(1)
    with pytest.raises(ValueError, match="has memory .* needs its agents' memory rows"):
        policy.logits(obs)
    memory = new_memory(4)
    policy.logits(obs, memory=memory)
    assert memory.any()  # the observations were folded in
    assert featurize(obs).shape[1] == NUM_PLANES
