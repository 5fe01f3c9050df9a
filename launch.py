"""ContactMPC entry point: compose the config, build the scene, run the selected job.

    python launch.py                         # one default trial; prints where its record is
    python launch.py task=doorknob seed=3    # override any config group or value
    python launch.py --cfg job               # print the composed config
    python launch.py job=render_scene task=stapler
    python launch.py -m task=apple,bottle seed=0,1,2   # a multirun sweep

Errors that come from bad input (config, reference files, scenes) are printed as one line naming the
problem, and the process exits with status 1.
"""

from __future__ import annotations

import functools
import json
import logging
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import hydra  # noqa: E402
from hydra.core.config_store import ConfigStore  # noqa: E402
from hydra.core.hydra_config import HydraConfig  # noqa: E402
from hydra.types import RunMode  # noqa: E402
from hydra.utils import instantiate  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from contactmpc.config import Config, check_config, member_schemas  # noqa: E402
from contactmpc.records import RECORD_NAME  # noqa: E402

CONF_DIR = Path(__file__).resolve().parent / "conf"

LABELS = ("task", "hand", "cost", "sampler", "planner", "variant", "preset", "experiment")
FINISHED = ("ok", "diverged")

log = logging.getLogger("contactmpc")


def conf_members(conf_dir: Path = CONF_DIR) -> list[tuple[str, str, str]]:
    """``(group, member, target)`` of every member file ``conf/<group>/<member>.yaml`` whose top level
    has a ``_target_``: the objects the config builds."""
    members = []
    for path in sorted(conf_dir.glob("*/*.yaml")):
        node = OmegaConf.load(path)
        if isinstance(node, DictConfig) and "_target_" in node:
            members.append((path.parent.name, path.stem, node._target_))
    return members


# (group, name, schema) triples stored in Hydra's ConfigStore: the root schema, and one schema per
# member, generated from the signature of what it builds (contactmpc.config.schema). A member's YAML
# names its target and lists "<member>_schema" in its defaults, so a typo in a key fails at compose
# time and every constructor parameter is settable; adding a member needs no other registration.
SCHEMAS = ((None, "config_schema", Config), *member_schemas(conf_members()))


def register_configs() -> None:
    """Store :data:`SCHEMAS` in Hydra's ConfigStore (idempotent)."""
    cs = ConfigStore.instance()
    for group, name, node in SCHEMAS:
        cs.store(group=group, name=name, node=node)


register_configs()


def build_scene(cfg: DictConfig):
    """Instantiate hand, task and scene from the composed config."""
    hand = instantiate(cfg.hand)
    task = instantiate(cfg.task)
    return instantiate(cfg.scene)(hand=hand, task=task)


def existing_record(output_dir: Path) -> dict | None:
    """The finished record in ``output_dir`` (status ok or diverged), if any: such jobs are skipped."""
    path = output_dir / RECORD_NAME
    if not path.exists():
        return None
    try:
        record = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    return record if record.get("status") in FINISHED else None


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def main(cfg: DictConfig) -> object:
    hc = HydraConfig.get()
    multirun = hc.mode == RunMode.MULTIRUN
    output_dir = Path(cfg.output_dir)
    done = existing_record(output_dir) if cfg.resume else None
    if done is not None:
        print(f"[contactmpc] skipped (record exists, status {done['status']}): {output_dir / RECORD_NAME}")
        return str(output_dir / RECORD_NAME)
    labels = {g: hc.runtime.choices.get(g) for g in LABELS}
    try:
        check_config(OmegaConf.to_container(cfg, resolve=True))  # nonsense values fail before any work
        job = instantiate(cfg.job)
        result = job(
            make_scene=functools.partial(build_scene, cfg),
            output_dir=output_dir,
            seed=cfg.seed,
            config=OmegaConf.to_container(cfg, resolve=True),
            labels=labels,
        )
    except Exception as err:
        # One line that names the problem; the trial's record (if it got that far) says the same.
        print(f"contactmpc: error: {type(err).__name__}: {' '.join(str(err).split())}", file=sys.stderr)
        if multirun:
            return None  # the sweep goes on with its other jobs
        sys.exit(1)
    print(f"[contactmpc] {cfg.job._target_.rsplit('.', 1)[-1]}: wrote {result}")
    return str(result)


if __name__ == "__main__":
    main()
