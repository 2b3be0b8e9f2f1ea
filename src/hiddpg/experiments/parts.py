"""Seed parts: one run of ``hiddpg reproduce`` trained as several runs over disjoint seeds.

A paper-scale run (15 seeds) can take longer than a machine is held. ``hiddpg reproduce FIG
--part 0-4`` trains seeds 0-4 of every run the figure needs as a run of their own
(``OUT/runs/<algo>-<task>.seeds-0-4/``), writes its artifact to
``OUT/parts/<algo>-<task>/seeds-0-4/`` and merges every part there into the run's artifact
``OUT/artifacts/<algo>-<task>/`` (:func:`merge_parts`), from which the figures are drawn with
the seeds merged so far. The parts are small enough to commit, so the next part can be trained
on another machine or another day.

A seed computes the same numbers in a part as in the whole run: its random streams and its
evaluation key depend on the seed alone, and on CPU the seeds of a run are computed one after
another (:mod:`hiddpg.devices`). So the merged artifact of parts covering every seed equals
the whole run's artifact, apart from meta.json (wall time: the parts' sum; ``parts``: what each
part is) and config.json (each part's creation time and versions move to ``parts``).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hiddpg.configs import TrainConfig
from hiddpg.experiments.artifacts import is_artifact, load_artifact, read_meta, write_artifact
from hiddpg.experiments.rundata import ExperimentError, RunData, Snapshot, TrainingBlocks
from hiddpg.runner import seed_ranges
from hiddpg.runs import CONFIG_FILE, Run

PARTS_DIR = "parts"
PART_KEYS = ("seeds", "hiddpg_version", "episodes", "wall_time", "status", "machines")
"""The entries of a part's meta.json that the merged artifact lists for it."""


def part_label(seeds: Sequence[int]) -> str:
    """The name of the part of ``seeds``: ``seeds-0-4``; ``seeds-0-4_7`` for 0..4 and 7."""
    return "seeds-" + "_".join(seed_ranges(seeds))


def is_merged(path: Path) -> bool:
    """Whether the artifact at ``path`` was merged from parts."""
    return is_artifact(path) and "parts" in read_meta(path)


def check_new_part(folder: Path, seeds: Sequence[int]) -> None:
    """:class:`ExperimentError` (one line) if other parts under ``folder`` hold some of
    ``seeds``: checked before the part is trained."""
    mine, common, holders = part_label(seeds), set(), []
    for path in sorted(folder.iterdir()) if folder.is_dir() else []:
        if path.name != mine and is_artifact(path):
            if found := set(read_meta(path)["seeds"]) & set(seeds):
                common |= found
                holders.append(path.name)
    if common:
        raise ExperimentError(f"seed(s) {sorted(common)} of --part "
                              f"{','.join(seed_ranges(seeds))} are in other parts already "
                              f"({', '.join(holders)} in {folder}); give seeds no part holds")


def holds_finished(artifact: Path, config: TrainConfig, seeds: Sequence[int],
                   part: bool) -> bool:
    """Whether the artifact on disk (committed, say, with its run directory gone) already
    holds ``seeds`` of the run of ``config``, trained to its episodes: then nothing is
    trained. :class:`ExperimentError` (one line) where training would contradict it: another
    config (episodes aside) or other seeds, a merged artifact short of seeds without
    ``part``, a whole run's artifact with ``part``."""
    if not is_artifact(artifact):
        return False
    meta, held = read_meta(artifact), Run.open(artifact)
    mine = dataclasses.replace(held.config, episodes=config.episodes)
    merged, have = "parts" in meta, [int(s) for s in meta["seeds"]]
    if mine != config or (not part and not merged and have != list(seeds)):
        diff = [f.name for f in dataclasses.fields(config)
                if getattr(mine, f.name) != getattr(config, f.name)]
        if not merged and not part and have != list(seeds):
            diff.append(f"seeds {have} != {list(seeds)}")
        raise ExperimentError(f"{artifact} holds a run with another config "
                              f"({', '.join(diff)}); remove it or choose another --out")
    if (meta.get("status") == "finished" and meta.get("episodes") == config.episodes
            and set(seeds) <= set(have)):
        return True
    if merged and not part:
        raise ExperimentError(f"{artifact} is merged from parts and holds seeds "
                              f"{','.join(seed_ranges(have))} of {','.join(seed_ranges(seeds))}; "
                              "train the others with --part, or choose another --out")
    if part and not merged:
        raise ExperimentError(f"{artifact} is the artifact of a whole run, not of parts; "
                              "remove it or choose another --out")
    return False


def merge_parts(folder: Path, dest: Path) -> Path:
    """Merge every part artifact under ``folder`` into the artifact ``dest`` (rewritten);
    :class:`ExperimentError` (one line, nothing written) if ``dest`` is a whole run's
    artifact or the parts do not fit together: another config, a seed in two parts, other
    evaluation episodes, training blocks or snapshots."""
    if is_artifact(dest) and not is_merged(dest):
        raise ExperimentError(f"{dest} is the artifact of a whole run, not of parts; remove "
                              "it or choose another --out")
    paths = sorted(p for p in folder.iterdir() if is_artifact(p)) if folder.is_dir() else []
    if not paths:
        raise ExperimentError(f"{folder} holds no part")
    parts = [(p, load_artifact(p), read_meta(p)) for p in paths]
    _check_fit(parts)
    data = _merged_data([d for _, d, _ in parts], dest)
    config = json.loads((paths[0] / CONFIG_FILE).read_text())
    records = []
    for p, _, meta in parts:
        own = json.loads((p / CONFIG_FILE).read_text())
        records.append({"part": p.name, **{k: meta[k] for k in PART_KEYS if k in meta},
                        "created": own.get("created"), "versions": own.get("versions")})
    config.pop("created", None)
    config.pop("versions", None)
    config["seeds"] = list(data.seeds)
    config_json = (json.dumps(config, indent=2) + "\n").encode()
    return write_artifact(data, config_json, _progress([m for _, _, m in parts]), dest,
                          parts=records)


def _check_fit(parts: list[tuple[Path, RunData, dict]]) -> None:
    (first, ref, ref_meta), seen = parts[0], {}
    for path, data, meta in parts:
        if data.config != ref.config:
            raise ExperimentError(f"parts {first.name} and {path.name} in {path.parent} have "
                                  "other configs; remove the one that does not belong")
        for seed in data.seeds:
            if seed in seen:
                raise ExperimentError(f"seed {seed} is in two parts, {seen[seed]} and "
                                      f"{path.name} ({path.parent}); remove one of them")
            seen[seed] = path.name
        what = [name for name, same in (
            ("episodes", meta.get("episodes") == ref_meta.get("episodes")),
            ("evaluation episodes", np.array_equal(data.episodes, ref.episodes)),
            ("training blocks", data.training.size == ref.training.size
             and np.array_equal(data.training.ends, ref.training.ends)),
            ("snapshots", meta.get("snapshot_episodes") == ref_meta.get("snapshot_episodes")),
        ) if not same]
        if what:
            raise ExperimentError(f"parts {first.name} and {path.name} in {path.parent} differ "
                                  f"in {', '.join(what)}; train both to the same episodes")


def _merged_data(parts: list[RunData], dest: Path) -> RunData:
    """The parts as one :class:`RunData`, its seeds in increasing order."""
    seeds = [s for d in parts for s in d.seeds]
    order = np.argsort(seeds, kind="stable")

    def cat(arrays: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(arrays, axis=0)[order]

    ref = parts[0]
    metrics = {c: cat([d.metrics[c] for d in parts]) for c in ref.metrics}
    blocks = TrainingBlocks(ref.training.size, ref.training.ends,
                            {c: cat([d.training.means[c] for d in parts])
                             for c in ref.training.means})
    per_part = [d.snapshots() for d in parts]
    snaps = [Snapshot(s.episode,
                      {k: cat([p[i].metrics[k] for p in per_part]) for k in s.metrics},
                      {k: cat([p[i].traj[k] for p in per_part]) for k in s.traj})
             for i, s in enumerate(per_part[0])]
    return RunData(dest, ref.config, tuple(int(seeds[i]) for i in order), ref.episodes,
                   metrics, blocks, lambda: snaps, {})


def _progress(metas: list[dict]) -> dict:
    """The merged run's progress: the parts' episodes, their summed wall time, ``finished``
    when every part is (else the first other status, with its error)."""
    other = next((m for m in metas if m.get("status") != "finished"), None)
    progress = {"episodes": metas[0].get("episodes"),
                "total_episodes": metas[0].get("total_episodes"),
                "wall_time": round(sum(float(m.get("wall_time") or 0.0) for m in metas), 3),
                "status": other["status"] if other else "finished"}
    if other and "error" in other:
        progress["error"] = other["error"]
    return progress
