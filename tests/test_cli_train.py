"""``morphkit train METHOD``: one subparser per method, chosen from a table named as the run loader's registry;
a flag of one method given to another is argparse's one-line refusal with exit code 2."""

from __future__ import annotations

import argparse

import pytest

from morphkit.cli import main
from morphkit.commands import train
from morphkit.commands.train import TRAINERS


def _own_flags(name: str) -> dict[str, bool]:
    """The flags method ``name`` adds beyond the shared ones, each with whether it takes a value."""
    p = argparse.ArgumentParser(add_help=False)
    TRAINERS[name].add_arguments(p)
    return {s: a.nargs != 0 for a in p._actions for s in a.option_strings}


FOREIGN = [(other, flag, takes_value) for name in TRAINERS for flag, takes_value in _own_flags(name).items()
           for other in TRAINERS if other != name]


@pytest.fixture
def started(monkeypatch: pytest.MonkeyPatch) -> list[argparse.Namespace]:
    """The train command's ``run`` replaced by one that keeps its arguments: nothing trains."""
    seen: list[argparse.Namespace] = []
    monkeypatch.setattr(train, "run", lambda args: seen.append(args) or 0)
    return seen


def test_the_method_table_names_the_run_loaders_methods():
    from morphkit.retarget.run_loader import METHODS

    assert set(TRAINERS) == set(METHODS)
    assert all(t.name == name for name, t in TRAINERS.items())


def test_an_ace_flag_is_foreign_to_nkn():
    assert ("nkn", "--no-adversarial", False) in FOREIGN and ("nkn", "--contact-weight", True) in FOREIGN


@pytest.mark.parametrize(("method", "flag", "takes_value"), FOREIGN)
def test_a_flag_of_another_method_is_refused_in_one_line(method, flag, takes_value, started, capsys):
    argv = ["train", method, "--preset", "smoke", flag, *(["1"] if takes_value else [])]
    assert main(argv) == 2
    assert capsys.readouterr().err == f"error: unrecognized arguments: {flag}\n"
    assert not started


@pytest.mark.parametrize("method", sorted(TRAINERS))
def test_each_method_takes_the_shared_flags(method, started, capsys):
    assert main(["train", method, "--preset", "smoke", "--out", "r", "--set", "seed=1", "--human-data", "h",
                 "--device", "cpu", "--no-progress"]) == 0
    (args,) = started
    assert (args.method, args.preset, args.out, args.set, args.human_data, args.device, args.no_progress) == (
        method, "smoke", "r", ["seed=1"], "h", "cpu", True)


def test_train_help_lists_the_methods(capsys):
    assert main(["train", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(f"    {name} " in out for name in TRAINERS), out


def test_a_missing_method_is_refused_with_the_train_usage(started, capsys):
    assert main(["train"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: morphkit train ") and err.endswith("error: the following arguments are required: "
                                                                       "METHOD\n")
    assert not started
