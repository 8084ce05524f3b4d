"""Run benchmarks/realism.py with every GT object of class FORCE_CLASS drawn as model FORCE_MODEL (an experiment)."""
import os, runpy, sys
import benchbot_worlds.homes.fitting as FIT
cls, model = os.environ["FORCE_CLASS"], os.environ["FORCE_MODEL"]
orig = FIT.choose_model
def choose(assets, *a, **k):
    if assets and all(getattr(x, "cls", None) == cls for x in assets):
        assets = [x for x in assets if x.id == model]
        assert assets, model
    return orig(assets, *a, **k)
import importlib, pkgutil, benchbot_worlds.homes as H
for m in pkgutil.iter_modules(H.__path__):
    mod = importlib.import_module(f"benchbot_worlds.homes.{m.name}")
    if getattr(mod, "choose_model", None) is orig:
        mod.choose_model = choose
        print("patched", m.name, file=sys.stderr)
sys.argv = ["benchmarks/realism.py"] + sys.argv[1:]
runpy.run_path("benchmarks/realism.py", run_name="__main__")
