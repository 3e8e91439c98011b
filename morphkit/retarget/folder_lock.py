"""The run-folder lock, now :mod:`morphkit._folder_lock` (a base layer, so ``synth`` and every command writing a
folder take it too); this name stays for existing imports."""

from morphkit._folder_lock import LOCK_FILE, hold_run_folder

__all__ = ["LOCK_FILE", "hold_run_folder"]
