"""Run benchmarks/realism.py with the furnishing's model choice patched (an experiment): every GT object of class
FORCE_CLASS drawn as model FORCE_MODEL; or (27 Nov, afternoon) asset REPLACE_OLD replaced by REPLACE_NEW wherever the
furnishing chooses it (same cuboid, same quarter turn). Needs BENCHBOT_SCENE_CACHE_BYTES=0."""
import os, runpy, sys
import benchbot_worlds.homes.fitting as FIT
cls, model = os.environ.get("FORCE_CLASS"), os.environ.get("FORCE_MODEL")
old, new = os.environ.get("REPLACE_OLD"), os.environ.get("REPLACE_NEW")
orig = FIT.choose_model
def choose(assets, *a, **k):
    if cls and assets and all(getattr(x, "cls", None) == cls for x in assets):
        assets = [x for x in assets if x.id == model]
        assert assets, model
    got = orig(assets, *a, **k)
    if old and got is not None and got[0].id == old:
        repl = [x for x in assets if x.id == new]
        assert repl, new
        got = (repl[0], got[1])
    return got
import importlib, pkgutil, benchbot_worlds.homes as H
for m in pkgutil.iter_modules(H.__path__):
    mod = importlib.import_module(f"benchbot_worlds.homes.{m.name}")
    if getattr(mod, "choose_model", None) is orig:
        mod.choose_model = choose
        print("patched", m.name, file=sys.stderr)
sys.argv = ["benchmarks/realism.py"] + sys.argv[1:]
runpy.run_path("benchmarks/realism.py", run_name="__main__")
