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

import logging
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import hydra  # noqa: E402
from hydra.core.config_store import ConfigStore  # noqa: E402
from hydra.core.hydra_config import HydraConfig  # noqa: E402
from hydra.utils import instantiate  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from contactmpc.config import SCHEMAS  # noqa: E402

log = logging.getLogger("contactmpc")


def register_configs() -> None:
    """Store the dataclass schemas of :mod:`contactmpc.config` in Hydra's ConfigStore."""
    cs = ConfigStore.instance()
    for group, name, node in SCHEMAS:
        cs.store(group=group, name=name, node=node)


register_configs()


def build_scene(cfg: DictConfig):
    """Instantiate hand, task and scene from the composed config."""
    hand = instantiate(cfg.hand)
    task = instantiate(cfg.task)
    return instantiate(cfg.scene)(hand=hand, task=task)


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def main(cfg: DictConfig) -> object:
    choices = HydraConfig.get().runtime.choices
    labels = {
        g: choices.get(g) for g in ("task", "hand", "cost", "sampler", "planner", "preset", "experiment")
    }
    try:
        scene = build_scene(cfg)
        job = instantiate(cfg.job)
        result = job(
            scene=scene,
            output_dir=Path(cfg.output_dir),
            seed=cfg.seed,
            config=OmegaConf.to_container(cfg, resolve=True),
            labels=labels,
        )
    except (ValueError, RuntimeError, OSError) as err:
        # Library errors are one line that names the problem (field, task, file).
        print(f"contactmpc: error: {' '.join(str(err).split())}", file=sys.stderr)
        sys.exit(1)
    print(f"[contactmpc] {cfg.job._target_.rsplit('.', 1)[-1]}: wrote {result}")
    return result


if __name__ == "__main__":
    main()
