"""``morphkit train METHOD ...``: train a retargeter into a run folder, one subcommand per method.

``morphkit train ace CREATURE`` (:mod:`._train_ace`) and ``morphkit train nkn [CREATURE]`` (:mod:`._train_nkn`):
:data:`TRAINERS` holds one entry per method, named as in :data:`morphkit.retarget.run_loader.METHODS`; each
method's subparser takes the flags every method shares (:func:`add_shared_arguments`) and its own, so argparse
refuses a flag of another method.
"""

from __future__ import annotations

import argparse
import contextlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from morphkit.commands import _args, _train_ace, _train_nkn


@dataclass(frozen=True)
class Trainer:
    """A method's ``morphkit train NAME`` subcommand."""

    name: str
    """The method's name, as in :data:`morphkit.retarget.run_loader.METHODS`."""
    help: str
    """Its line in ``morphkit train --help``."""
    description: str
    """Its ``morphkit train NAME --help`` text."""
    out: str
    """Its default run folder, for ``--out``'s help."""
    sets: str
    """Examples of ``--set`` for its config, for ``--set``'s help."""
    add_arguments: Callable[[argparse.ArgumentParser], None]
    """Adds its CREATURE argument and its own flags."""
    run: Callable[[argparse.Namespace], int]
    """Trains it from the parsed arguments; returns the exit code."""


TRAINERS: dict[str, Trainer] = {t.name: t for t in (
    Trainer("ace", "ACE (Li et al. 2023) for CREATURE: a motion prior, then an adversarial retargeter",
            "Train ACE (Li et al. 2023) for CREATURE: synthesise its motion, pre-train its motion prior, then the "
            "adversarial retargeter from human motion. The run folder holds configs, checkpoints (resumed "
            "automatically), metrics.csv and TensorBoard logs. Under torchrun it trains with DDP.",
            "runs/ace_<creature>_<preset>", "--set prior.epochs=10 --set retarget.w_fea=2",
            _train_ace.add_arguments, _train_ace.run),
    Trainer("nkn", "NKN: without CREATURE the paper's NKN between the human skeletons and bone-length variants; "
            "with one its cross-morphology mode",
            "Train NKN (Villegas et al. 2018): without CREATURE the paper's same-topology mode over the human "
            "skeletons and their bone-length variants, with one the cross-morphology mode (human → CREATURE). The "
            "run folder holds configs, checkpoints (resumed automatically), metrics.csv and TensorBoard logs.",
            "runs/nkn_<data>[_<creature>]_<preset>", "--set epochs=10 --set twist_weight=5",
            _train_nkn.add_arguments, _train_nkn.run),
)}
"""One entry per method, keyed by its name (``morphkit train NAME``)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "train",
        help="train a retargeter (ACE for a creature, or NKN); re-running the same command resumes it",
        description="Train a retargeter into a run folder; re-running the same command resumes it. "
                    "`morphkit train METHOD --help` lists a method's options.",
    )
    methods = p.add_subparsers(dest="method", metavar="METHOD", parser_class=type(p))
    methods.required = True
    for trainer in TRAINERS.values():
        q = methods.add_parser(trainer.name, help=trainer.help, description=trainer.description)
        add_shared_arguments(q, out=trainer.out, sets=trainer.sets)
        trainer.add_arguments(q)
        q.set_defaults(run=run)


def add_shared_arguments(p: argparse.ArgumentParser, *, out: str, sets: str) -> None:
    """The flags every method's ``train`` subcommand takes; ``out`` (its default run folder) and ``sets``
    (examples of ``--set``) go into their help."""
    p.add_argument("--human-data", metavar="DIR",
                   help="human motion folder or file (BVH, NPZ, USD); default: the embedded default human motion; "
                   "CMU evaluation clips are left out")
    p.add_argument("--preset", default="quick", help="smoke, quick, default or paper (default: quick)")
    p.add_argument("--out", type=_args.out_path, metavar="RUN", help=f"run folder (default: {out})")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                   help=f"override a config field, e.g. {sets} (repeatable)")
    p.add_argument("--device", default=None, help="torch device (default: cuda when present, else cpu)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")


def hold_for_command(out: Path) -> contextlib.AbstractContextManager[None]:
    """The run folder's lock (:mod:`morphkit._folder_lock`) for the whole command; under torchrun rank 0
    takes it alone (the other ranks of the job share the folder by design)."""
    from morphkit._folder_lock import hold_run_folder

    return hold_run_folder(out) if os.environ.get("RANK", "0") == "0" else contextlib.nullcontext()


def run(args: argparse.Namespace) -> int:
    """Train the method the command line named."""
    return TRAINERS[args.method].run(args)
