"""The model card of a PPO policy shipped from a run (`train --export`), redrawn with its results
table by `report --card`.

The card is drawn from what the job hands it, all read from the policy folder by
`runs/history.exported_training`, so it can be redrawn after the run has moved on or is gone:

- the source (`source.json`, written by `runs/export.export_policy`): the run, trial and
  checkpoint it came from, the checkpoint's iteration, the curriculum (name, description, every
  stage), the commit it was exported at and the commits that packed the run; optionally
  `chosen`, a person's reason for shipping this checkpoint rather than the run's end (say, the
  last one before a collapse), which the card states instead of "training goes on";
- its training (`viz/training.Training`, from the run's summary rows up to that checkpoint),
  which gives Fig. 3, the stage table and the totals;
- optionally `NOTES.md` in the folder: words of a person, kept as they are under "Notes".

Arena records (`evaluate --records`, e.g. `benchmarks/paper_table.py --team ppo`) add the paper's
Table 3 layout and Fig. 4.
"""

from __future__ import annotations

from pathlib import Path

from ..imitation.features import NUM_PLANES
from ..imitation.recall import MEMORY_PLANES, RECALL_PLANES
from .report import fig3_section, tables_section
from .training import Training

CARD_FILE = "MODEL_CARD.md"
NOTES_FILE = "NOTES.md"


# What the exported pi is, by the curriculum's game (an older source.json names none: Team).
NETS = {"team": "The paper's CNN",
        "radio": "TeamRadio: the paper's CNN hearing its teammate's two words and speaking two "
                 "(`RadioNet`)"}


def _schedule(curriculum: dict) -> str:
    lines = ["| stage | games | opponents | teammate | reward | action filter | jitter "
             "correction | pi |", "|---" * 8 + "|"]
    for s in curriculum["stages"]:
        league = [s["opponent"]] if isinstance(s["opponent"], str) else s["opponent"]
        opponents = ", ".join(f"`{name}`" for name in league)
        lines.append(f"| {s['name']} | {s['episodes']:,} | {opponents} | `{s['teammate']}` "
                     f"| {s['reward']} | {s['action_filter']:.0%} of games | {s['jitter']:.0%} of "
                     f"games | {'frozen' if s['freeze_pi'] else 'trained'} |")
    return "\n".join(lines)


def _planes(curriculum: dict) -> str:
    """What pi reads: the paper's planes, and the memory planes where the run kept memory."""
    if curriculum.get("memory"):
        return (f"{MEMORY_PLANES} feature planes (the paper's {NUM_PLANES}, then {RECALL_PLANES} "
                f"of what each agent saw under the fog, so it plays with a memory of its own "
                f"observations)")
    return f"{NUM_PLANES} feature planes"


def _start_lines(source: dict, games: int) -> list[str]:
    """Where pi began, where `runs/export.starting_policy` could prove it, and the games
    counted from the clone its lineage starts at (`history.lineage`)."""
    if not source.get("pi_start"):
        return []
    lines = [f"- pi started from `{source['pi_start']}` (proven by equal weights: its `pi.pt` is "
             f"the file whose digest the run noted at its start, or equals pi at the end of the "
             f"run's pi-frozen first stage)"]
    chain = source.get("lineage") or []
    if len(chain) > 1:
        clone, *trained = chain
        before = sum(link["games"] for link in trained)
        steps = " + ".join(f"{link['games']:,} as `{link['policy']}`" for link in trained)
        lines.append(f"- games counted from the imitation clone `{clone['policy']}`: {steps} + "
                     f"{games:,} in this run = **{before + games:,}**")
    return lines


def _preface(source: dict, training: Training) -> list[str]:
    curriculum = source["curriculum"]
    total = sum(s["episodes"] for s in curriculum["stages"])
    games = sum(stage.episodes for stage in training.stages)
    hours = sum(stage.seconds for stage in training.stages) / 3600
    finished = games >= total
    if finished:
        status = "the whole curriculum"
    elif source.get("chosen"):
        status = (f"**{games / total:.0%} of the curriculum, chosen over the run's end**: "
                  f"{source['chosen']}")
    else:
        status = (f"**{games / total:.0%} of the curriculum: training goes on**, and this card "
                  f"and the weights are replaced as it does")
    commits = source["run_commits"]
    steps = sum(stage.env_steps for stage in training.stages)
    title = curriculum["description"].rstrip(".")
    return [
        f"# Model card: `{source['policy']}` ({title})",
        f"The learner of the PPO run `{source['run']}` (curriculum `{curriculum['name']}`), "
        f"exported from `{source['checkpoint']}` at training iteration {source['iteration']:,}: "
        f"{games:,} of {total:,} games, {status}. {NETS[curriculum.get('game', 'team')]} "
        f"(`pi.pt`, a plain state_dict "
        f"for `torch.load(weights_only=True)`), {_planes(curriculum)}, sampling its actions as it "
        f"did in training; the variants `{source['policy']}_jitter`, `_action` and "
        f"`_jitter_action` add the paper's filters.",
        "## Training",
        "\n".join([
            f"- games: {games:,}; env steps: {steps:,}; training time: {hours:.1f} hours (the "
            f"run's `time_total_s`: its iterations, sessions added up)",
            *_start_lines(source, games),
            f"- code: exported at commit `{source['exported_at_commit']}`; the run was packed and "
            f"committed {len(commits)} time(s) ({', '.join(f'`{c}`' for c in commits) or 'never'}"
            f"), each session training with the code of the commit before its pack",
            f"- curriculum `{curriculum['name']}`:"]),
        _schedule(curriculum),
    ]


def write_model_card(policy_dir: Path, source: dict, training: Training,
                     records: list[Path] = ()) -> Path:
    """`policy_dir`/MODEL_CARD.md with Fig. 3 and the stage table from `training`, the results
    tables and Fig. 4 from `records` (none: a pointer to the command that plays them), and
    NOTES.md; PNGs beside it."""
    policy_dir = Path(policy_dir)
    parts = _preface(source, training)
    parts += list(fig3_section(training, policy_dir))
    play = (f"`python benchmarks/paper_table.py --team {source['policy']} --games 1000 --out "
            f"RECORDS` (the paper's rows that name a policy we have; seed 0, seats balanced), "
            f"then `python -m rllib_pommer.report --card {policy_dir} RECORDS/*.jsonl.gz`")
    if records:
        parts += list(tables_section(list(records), policy_dir))
        parts.append(f"From {len(records)} arena record files; played by {play}.")
    else:
        parts += ["## Results", f"Not played yet: {play}."]
    notes = policy_dir / NOTES_FILE
    if notes.is_file():
        parts += ["## Notes", notes.read_text().strip()]
    card = policy_dir / CARD_FILE
    card.write_text("\n\n".join(parts) + "\n")
    return card
