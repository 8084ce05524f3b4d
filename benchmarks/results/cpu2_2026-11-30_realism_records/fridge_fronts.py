"""fridge_fronts.py [--no-rule] [--version V] START COUNT: the procedural validation homes START..START+COUNT-1 of
generator version V (default the current one) as the generator makes them (``generate_home``, no cache), and how
many of their refrigerators have a floor object (a table, a chair, a sink) in the strip ``FRIDGE_FRONT_M`` (0.9 m)
deep in front of them, by the check of ``test_the_floor_in_front_of_every_refrigerator_is_clear``
(plugins/worlds/tests/test_procedural_generator.py). ``--no-rule`` makes them with the rule off (``FRIDGE_FRONT_M``
0: no strip kept), as before it. Also the objects made and the objects the generator dropped (its notes). Run from
the repository root (docs/history/realism-2026-11.md, *The floor in front of the fridge kept clear: generator v3*):

    uv run python benchmarks/results/cpu2_2026-11-30_realism_records/fridge_fronts.py --version 2 --no-rule 0 20
"""
import argparse
import sys

sys.path.insert(0, "plugins/worlds/tests")
from test_procedural_generator import _blocked_fridge_fronts, _union  # noqa: E402

from benchbot_worlds.procedural import objects, splits  # noqa: E402
from benchbot_worlds.procedural.generator import GENERATOR_VERSION, generate_home  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("start", type=int)
    ap.add_argument("count", type=int)
    ap.add_argument("--version", type=int, default=GENERATOR_VERSION)
    ap.add_argument("--no-rule", action="store_true")
    args = ap.parse_args()
    if args.start < 0 or args.count < 1 or args.version < 1:
        sys.exit("START must be >= 0, COUNT and --version >= 1")
    front = objects.FRIDGE_FRONT_M
    if args.no_rule:
        objects.FRIDGE_FRONT_M = 0.0
    fridges = blocked = made = dropped = 0
    for i in range(args.start, args.start + args.count):
        home = generate_home(splits.home_seed("val", i, args.version), f"procedural_val_{i}")
        union = _union(home)
        made += len(union)
        dropped += sum("dropped" in n for n in home.notes)
        fridges += sum(o["class"] == "refrigerator" for o in union)
        pairs = _blocked_fridge_fronts(home)
        blocked += len({f for f, _ in pairs})
        for f, other in pairs:
            print(f"procedural_val_{i}: {f} has {other} in front")
    print(f"{args.count} homes (seeds of v{args.version}, rule {'off' if args.no_rule else 'on'}): {fridges} fridges, "
          f"{blocked} with a floor object within {front} m in front; {made} objects made, {dropped} dropped")


if __name__ == "__main__":
    main()
