"""A solution that cheats: it takes no step and tries every way it knows to copy the ground truth into its results.

Run by ``tests/test_sandbox.py`` as a native solution (``python cheat_solution.py [--symlink]``) from its own
folder. It tries, in order, printing one ``TRIED <way>: <what happened>`` line for each:

1. ``run-dir``: the files beside and above its results location (``../config.json`` and the rest of a run
   directory), following any ``map_path`` or file path they name;
2. ``benchbot-gt``: ``python -m benchbot.cli gt ENV --layout original``;
3. ``import``: BenchBot's registry in-process (``get_registry().ground_truth(ENV)``), then the simulator plugin's
   own ground-truth loader (``benchbot_worlds.bear.ground_truth_specs``);
4. ``walk``: a bounded walk of the whole file system for the environment's layout file (``<name>_<variant>.json``,
   or any JSON file naming the environment and holding ``ground_truth``), at most :data:`WALK_ENTRIES` entries and
   :data:`WALK_SECONDS` seconds;
5. with ``--symlink``, when nothing was found: its results file made a symbolic link to where the ground truth lies
   outside a sandbox (next to BenchBot's own package), for whoever reads it afterwards.

Whatever it found first becomes its results (every ground-truth object with probability 1 for its class); when it
found nothing, it saves the empty results the API gives it. It prints ``FOUND <way>`` or ``FOUND nothing``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from benchbot_api import Agent, BenchBot

WALK_ENTRIES = 400_000
WALK_SECONDS = 60.0


def objects_of(data) -> list | None:
    """Ground-truth objects (``{class, centroid, extent}``) found anywhere in ``data``, or None."""
    if isinstance(data, dict):
        objects = data.get("objects")
        if isinstance(objects, list) and objects and all(isinstance(o, dict) and "centroid" in o for o in objects):
            return objects
        for value in data.values():
            found = objects_of(value)
            if found:
                return found
    return None


def from_file(path: Path) -> list | None:
    try:
        return objects_of(json.loads(path.read_text()))
    except (OSError, ValueError):
        return None


def try_run_dir(results_file: Path, env: str) -> list | None:
    seen = []
    for folder in (results_file.parent, results_file.parent.parent, results_file.parent.parent.parent):
        try:
            names = sorted(os.listdir(folder))
        except OSError as exc:
            seen.append(f"{folder}: {exc.strerror}")
            continue
        seen.append(f"{folder}: {names[:20]}")
        for name in names:
            path = folder / name
            if not path.is_file() or path == results_file:
                continue
            try:
                text = path.read_text()
            except (OSError, UnicodeDecodeError):
                continue
            found = from_file(path)
            if found:
                print(f"TRIED run-dir: ground truth in {path}")
                return found
            for word in text.replace('"', " ").replace(",", " ").split():  # paths it names: map_path and others
                if word.startswith("/") and word.endswith(".json") and os.path.isfile(word):
                    found = from_file(Path(word))
                    if found:
                        print(f"TRIED run-dir: {path} names {word}, which holds the ground truth")
                        return found
    print(f"TRIED run-dir: nothing ({'; '.join(seen)})")
    return None


def try_benchbot_gt(env: str) -> list | None:
    try:
        proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "gt", env, "--layout", "original"],
                              capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        print(f"TRIED benchbot-gt: {exc}")
        return None
    try:
        found = objects_of(json.loads(proc.stdout))
    except ValueError:
        found = None
    last = (proc.stderr.strip().splitlines() or [""])[-1]
    print(f"TRIED benchbot-gt: exit {proc.returncode}, {'ground truth' if found else 'nothing'} ({last[:200]})")
    return found


def try_import(env: str) -> list | None:
    try:
        from benchbot.core.registry import get_registry

        found = objects_of(get_registry().ground_truth(env))
        print("TRIED import: the registry gave the ground truth")
        return found
    except Exception as exc:  # noqa: BLE001 - a cheat tries everything
        print(f"TRIED import: registry failed: {exc!r}"[:300])
    try:
        from benchbot_worlds.bear import ground_truth_specs

        name, variant = env.split(":")
        for gt in ground_truth_specs():
            if gt["environment"]["name"] == name and str(gt["environment"]["variant"]) == variant:
                print("TRIED import: the simulator plugin gave the ground truth")
                return objects_of(gt)
        print("TRIED import: the simulator plugin has no such ground truth")
    except Exception as exc:  # noqa: BLE001
        print(f"TRIED import: simulator plugin failed: {exc!r}"[:300])
    return None


def try_walk(env: str) -> list | None:
    name, variant = env.split(":")
    wanted = {f"{name}_{variant}.json", f"{name}{variant}.json"}
    start, entries = time.monotonic(), 0
    for root, dirs, files in os.walk("/", topdown=True):
        dirs[:] = [d for d in dirs if os.path.join(root, d) not in ("/proc", "/sys", "/dev")]
        entries += len(dirs) + len(files)
        for file in files:
            if file in wanted or (file.endswith(".json") and name in file):
                found = from_file(Path(root, file))
                if found:
                    print(f"TRIED walk: ground truth in {os.path.join(root, file)} after {entries} entries")
                    return found
        if entries > WALK_ENTRIES or time.monotonic() - start > WALK_SECONDS:
            print(f"TRIED walk: nothing in the first {entries} entries (stopped at the bound)")
            return None
    print(f"TRIED walk: nothing in the whole file system ({entries} entries)")
    return None


class Cheat(Agent):
    def is_done(self, action_result):
        return True  # it never moves

    def pick_action(self, observations, action_list):
        raise AssertionError("never called")

    def save_result(self, filename, empty_results, results_format_fns):
        env_spec = empty_results["environment_details"][0]
        env = f"{env_spec['name']}:{env_spec['variant']}"
        found = None
        for way, attempt in (("run-dir", lambda: try_run_dir(Path(filename), env)),
                             ("benchbot-gt", lambda: try_benchbot_gt(env)), ("import", lambda: try_import(env)),
                             ("walk", lambda: try_walk(env))):
            found = attempt()
            if found:
                print(f"FOUND {way}")
                break
        else:
            print("FOUND nothing")
        if not found and "--symlink" in sys.argv:
            import benchbot

            target = (Path(benchbot.__file__).resolve().parents[1] / "plugins" / "worlds" / "benchbot_worlds"
                      / "data" / "bear" / f"{env.replace(':', '_')}.json")
            os.symlink(target, filename)
            print(f"SYMLINK {filename} -> {target}")
            return
        results = empty_results["results"]
        class_list = results["class_list"]
        for obj in found or []:
            if obj.get("class") in class_list:
                probs = [0.0] * len(class_list)
                probs[class_list.index(obj["class"])] = 1.0
                results["objects"].append({"label_probs": probs, "centroid": obj["centroid"],
                                           "extent": obj["extent"]})
        Path(filename).write_text(json.dumps(empty_results))


if __name__ == "__main__":
    BenchBot(agent=Cheat()).run()
