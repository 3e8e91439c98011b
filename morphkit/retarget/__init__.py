"""Trainer layer: shared run machinery (config, checkpoints, exact resume, logs, torchrun), the data every
trainer reads, the retargeter protocol, and network building blocks.

Torch only: trainers reach the kernels through ``morphkit.torch``, never Warp directly, and never
name a creature. Method packages (``ace/``, ``nkn/``) build on this.

* :mod:`~morphkit.retarget.config`: frozen-dataclass configs as YAML, type-checked, presets and overrides.
* :mod:`~morphkit.retarget.checkpoint`: atomic, ``weights_only``-loadable checkpoints; every RNG state.
* :mod:`~morphkit.retarget.training_run`: :class:`Run`, the run folder and the resumable training loop.
* :mod:`~morphkit.retarget.logs`: ``metrics.csv`` and TensorBoard events.
* :mod:`~morphkit.retarget.distributed`: DistributedDataParallel under ``torchrun``.
* :mod:`~morphkit.retarget.networks`: activations by name, MLPs, FLOP counting.
* :mod:`~morphkit.retarget.training_data`: the data every trainer reads (character and human motion, the split).
* :mod:`~morphkit.retarget.retargeter`: the :class:`Retargeter` protocol.
* :mod:`~morphkit.retarget.run_loader`: :func:`load`, any trained run folder as a :class:`Retargeter`.
"""

from morphkit.retarget.checkpoint import CHECKPOINT_FORMAT as CHECKPOINT_FORMAT
from morphkit.retarget.checkpoint import CHECKPOINT_VERSION as CHECKPOINT_VERSION
from morphkit.retarget.checkpoint import load_checkpoint as load_checkpoint
from morphkit.retarget.checkpoint import rng_state as rng_state
from morphkit.retarget.checkpoint import save_checkpoint as save_checkpoint
from morphkit.retarget.checkpoint import set_rng_state as set_rng_state
from morphkit.retarget.config import PRESET_NAMES as PRESET_NAMES
from morphkit.retarget.config import config_diff as config_diff
from morphkit.retarget.config import config_from_dict as config_from_dict
from morphkit.retarget.config import config_to_dict as config_to_dict
from morphkit.retarget.config import parse_overrides as parse_overrides
from morphkit.retarget.config import preset_config as preset_config
from morphkit.retarget.config import read_config as read_config
from morphkit.retarget.config import replace_config as replace_config
from morphkit.retarget.config import write_config as write_config
from morphkit.retarget.distributed import DistributedContext as DistributedContext
from morphkit.retarget.distributed import all_gather_objects as all_gather_objects
from morphkit.retarget.distributed import all_reduce_max as all_reduce_max
from morphkit.retarget.distributed import all_reduce_mean as all_reduce_mean
from morphkit.retarget.distributed import init_distributed as init_distributed
from morphkit.retarget.distributed import unwrap as unwrap
from morphkit.retarget.distributed import wrap_ddp as wrap_ddp
from morphkit.retarget.logs import METRICS_CSV as METRICS_CSV
from morphkit.retarget.logs import TENSORBOARD_DIR as TENSORBOARD_DIR
from morphkit.retarget.logs import MetricsLog as MetricsLog
from morphkit.retarget.logs import read_metrics as read_metrics
from morphkit.retarget.networks import MLP as MLP
from morphkit.retarget.networks import make_activation as make_activation
from morphkit.retarget.networks import matmul_flops as matmul_flops
from morphkit.retarget.retargeter import RetargetedClip as RetargetedClip
from morphkit.retarget.retargeter import Retargeter as Retargeter
from morphkit.retarget.retargeter import WithContacts as WithContacts
from morphkit.retarget.run_loader import load as load
from morphkit.retarget.training_run import CHECKPOINT_FILE as CHECKPOINT_FILE
from morphkit.retarget.training_run import CONFIG_FILE as CONFIG_FILE
from morphkit.retarget.training_run import RUN_FILE as RUN_FILE
from morphkit.retarget.training_run import Run as Run
from morphkit.retarget.training_run import Stateful as Stateful
from morphkit.retarget.training_run import derive_seed as derive_seed

__all__ = [
    "CHECKPOINT_FILE",
    "CHECKPOINT_FORMAT",
    "CHECKPOINT_VERSION",
    "CONFIG_FILE",
    "METRICS_CSV",
    "MLP",
    "PRESET_NAMES",
    "RUN_FILE",
    "TENSORBOARD_DIR",
    "DistributedContext",
    "MetricsLog",
    "RetargetedClip",
    "Retargeter",
    "Run",
    "Stateful",
    "WithContacts",
    "all_gather_objects",
    "all_reduce_max",
    "all_reduce_mean",
    "config_diff",
    "config_from_dict",
    "config_to_dict",
    "derive_seed",
    "init_distributed",
    "load",
    "load_checkpoint",
    "make_activation",
    "matmul_flops",
    "parse_overrides",
    "preset_config",
    "read_config",
    "read_metrics",
    "replace_config",
    "rng_state",
    "save_checkpoint",
    "set_rng_state",
    "unwrap",
    "wrap_ddp",
    "write_config",
]
