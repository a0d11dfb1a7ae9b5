"""A hand-written H+L policy: what the H+L baselines' action space (each robot's own point goal, walked to by the
go-to-point controller; `mapush/envs/nav_high.py`) allows, with no learning. Prints S.R. and C.T. over fresh
episodes on evaluation maps (OMPL paths), to hold against the learned H+L and H+L FT cells.

Each robot, every decision: the push direction u points from the object to the path point ahead
(`subgoal_xy`). A robot behind the object (within its half-width `--reach` of the push line, on the far side)
walks on along u through the object; any other robot walks to a staging point `--behind` metres behind the object
along -u, spread sideways by its index. Goals are clipped to the action range (`level.robot_goal_range_m`).

    python tools/hl_scripted.py task=cuboid --envs 20      # overrides as for `mapush eval`
"""

from __future__ import annotations

import argparse

import torch

from mapush.config import compose_config, to_plain
from mapush.envs.observations import target_heading
from mapush.eval.rollout import first_episodes
from mapush.levels import make_env
from mapush.planning.geometry import rotate
from mapush.rl.vecenv import AgentRowsVecEnv, to_rows


def scripted_actions(env, reach: float, behind: float) -> torch.Tensor:
    """(E, A, 2) actions in [-1, 1]: the goal offsets above, in the target frame, over the goal range."""
    s = env.state
    u = env.subgoal_xy - s.object_xy
    u = u / torch.linalg.vector_norm(u, dim=-1, keepdim=True).clamp_min(1e-6)  # (E, 2)
    side = torch.stack([-u[:, 1], u[:, 0]], -1)
    rel = s.robot_xy - s.object_xy.unsqueeze(1)  # (E, A, 2)
    along, across = (rel * u.unsqueeze(1)).sum(-1), (rel * side.unsqueeze(1)).sum(-1)
    pushing = (along < 0) & (across.abs() < reach)
    A = env.num_agents
    spread = (torch.arange(A) - (A - 1) / 2) * (2 * reach / max(A, 1))  # sideways slots behind the object
    staging = s.object_xy.unsqueeze(1) - behind * u.unsqueeze(1) + spread.view(1, A, 1) * side.unsqueeze(1)
    onward = s.robot_xy + 2.0 * u.unsqueeze(1)
    goal = torch.where(pushing.unsqueeze(-1), onward, staging)
    offset = rotate(goal - s.robot_xy, -target_heading(env).unsqueeze(1).expand(-1, A))
    return (offset / env.cfg["level"]["robot_goal_range_m"]).clamp(-1.0, 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("overrides", nargs="*")
    parser.add_argument("--envs", type=int, default=20, help="episodes (one per env)")
    parser.add_argument("--reach", type=float, default=0.6, help="m; half-width of the pushing band")
    parser.add_argument("--behind", type=float, default=1.4, help="m; staging distance behind the object centre")
    args = parser.parse_args()
    cfg = to_plain(compose_config(["level=high_nav", "reward=high_nav", "seed=0", *args.overrides]))
    env = make_env({**cfg, "num_envs": args.envs}, evaluation=True)
    outcome = first_episodes(
        env, AgentRowsVecEnv(env), lambda _: to_rows(scripted_actions(env, args.reach, args.behind)), 0
    )
    print(f"{cfg['task']['name']}: S.R. {100 * outcome['success_rate']:.1f} % over {args.envs} episodes, "
          f"C.T. {outcome['completion_time']:.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
