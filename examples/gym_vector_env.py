"""Several BenchBot robots stepped together as one Gymnasium vector environment (docs/gym.md).

    python examples/gym_vector_env.py [--num-envs 2] [--steps 20] [--env miniroom:1] [--width 160 --height 120]
        [--mode batched|sync]

``--mode batched`` (the default, ``gym.make_vec``'s own for ``BenchBot-v0``): N robots in one scene, moved together
and rendered in one launch per step (``benchbot.gym_vector``). ``--mode sync``: N in-process simulators, each built by
``gym.make("BenchBot-v0", ...)`` and stepped in turn, each reseeded from ``reset(seed=...)`` (seed, seed + 1, ...) so
their object colours differ. Either way a sub-environment that terminates (a collision) or is truncated is reset on
its next step. Random actions stand in for a policy.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import benchbot.gym  # noqa: F401  (registers BenchBot-v0)


def main(argv: list[str] | None = None) -> None:
    """Run ``--steps`` random steps of ``--num-envs`` simulators and print what came back.

    Raises:
        benchbot.core.errors.SpecError: an unknown task, environment or robot.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=2)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--task", default="semantic_slam:active:ground_truth")
    parser.add_argument("--env", default="miniroom:1", help="environment NAME:VARIANT")
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=120)
    parser.add_argument("--mode", choices=["batched", "sync"], default="batched",
                        help="batched: N robots, one simulator; sync: N simulators")
    args = parser.parse_args(argv)

    mode = "vector_entry_point" if args.mode == "batched" else "sync"
    envs = gym.make_vec("BenchBot-v0", num_envs=args.num_envs, vectorization_mode=mode, task=args.task,
                        env=args.env, options={"width": args.width, "height": args.height}, max_steps=50)
    try:
        obs, info = envs.reset(seed=0)
        rng = np.random.default_rng(0)
        collisions = 0
        for _ in range(args.steps):
            actions = rng.integers(0, envs.single_action_space.n, size=args.num_envs)  # a policy goes here
            obs, rewards, terminated, truncated, info = envs.step(actions)
            collisions += int(np.sum(terminated))
        print(f"{args.num_envs} environments ({args.mode}), {args.steps} steps, {collisions} collisions")
        for key, value in obs.items():
            print(f"  {key} {value.shape} {value.dtype}")
        print(f"  poses [x, y, yaw]: {np.round(obs['pose'], 3).tolist()}")
    finally:
        envs.close()


if __name__ == "__main__":
    main()
