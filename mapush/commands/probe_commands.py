"""What `mapush probe` does (`mapush.cli.probe` reads its arguments): commands, falls, progress, paths, reversals,
squeeze, contacts. The figures come from `mapush.eval.probes` and `mapush.calibration`'s reversals, squeeze and
contacts."""

from __future__ import annotations

from pathlib import Path

from mapush.commands.arguments import number_list
from mapush.errors import BadInput


def _check_episodes(episodes: int, target: Path | None = None) -> None:
    """Bad input told before the simulator and PyTorch load: a count below 1, a missing run or checkpoint."""
    if episodes < 1:
        raise BadInput(f"--episodes {episodes} must be a positive count; valid: 1 or more")
    if target is not None:
        from mapush.rundir import resolve_checkpoint

        resolve_checkpoint(target)


def commands(target: Path, episodes: int, overrides: list[str]) -> None:
    """`mapush probe commands`: a mid level's velocity commands as shares of its action scale."""
    _check_episodes(episodes, target)
    from mapush.eval.probes import probe_commands

    probe_commands(target, episodes, overrides)


def falls(target: Path, episodes: int, overrides: list[str], go_on: bool, replay: int) -> None:
    """`mapush probe falls`: where a hierarchy's Go1s fall; with `replay`, the commands before each fall replayed
    on that many free robots."""
    _check_episodes(episodes, target)
    if replay < 0:
        raise BadInput(f"--replay {replay} must be a count; valid: 0 (none) or more")
    from mapush.eval.probes import probe_falls

    watch = probe_falls(target, episodes, overrides, go_on)
    if replay and watch.histories:
        from mapush.calibration.reversals import replay_sweep

        robot = _robot([a for a in overrides if a.startswith(("lowlevel", "sim."))])
        found = replay_sweep(robot, watch.histories, watch.dt, replay)
        print(f"  replayed free ({' '.join(robot)}), {replay} robots a fall, the {len(watch.histories)} falls with "
              f"{len(watch.histories[0]) * watch.dt:g} s of commands: {found['fell'].mean():.2f} fell; "
              f"falls with any replay fallen: {int((found['fell'] > 0).sum())}")  # fmt: skip


def progress(target: Path, episodes: int, compare: list[str]) -> None:
    """`mapush probe progress`: where a mid level's pushes take the object, as trained and with `compare`."""
    _check_episodes(episodes, target)
    from mapush.eval.probes import probe_progress

    probe_progress(target, episodes, compare)


def paths(tasks: str, episodes: int, seed: int, overrides: list[str]) -> None:
    """`mapush probe paths`: the lengths of the paths the high level is evaluated on, per object of `tasks`."""
    _check_episodes(episodes)
    from mapush.eval.probes import path_lengths

    path_lengths([t for t in tasks.split(",") if t], episodes, seed, overrides)


def reversals(overrides: list[str], envs: int, seconds: float, seed: int) -> None:
    """`mapush probe reversals`: how often a low level's robot falls under reversing full-scale commands."""
    if envs < 1 or not seconds > 0:
        raise BadInput(f"--envs {envs} --seconds {seconds:g}; valid: --envs 1 or more, --seconds above 0")
    from mapush.calibration.reversals import print_reversals

    print_reversals(_robot(overrides), envs, seconds, seed)


def squeeze(overrides: list[str], envs: int, seed: int) -> None:
    """`mapush probe squeeze`: how often a low level's robot falls squeezed between the object and teammates."""
    if envs < 1:
        raise BadInput(f"--envs {envs}; valid: --envs 1 or more")
    from mapush.calibration.squeeze import print_squeeze

    print_squeeze(_robot(overrides), envs, seed)


def contacts(overrides: list[str], speeds: str, envs: int, seed: int) -> None:
    """`mapush probe contacts`: which parts of a low level's robot push an object alone, how hard, how fast."""
    values = number_list(speeds, "--speeds", kind=float, minimum=0.01)
    if envs < 1:
        raise BadInput(f"--envs {envs}; valid: --envs 1 or more")
    from mapush.calibration.contacts import print_contacts

    print_contacts(_robot(overrides), values, envs, seed)


def _robot(overrides: list[str]) -> list[str]:
    """The overrides of a low-level probe: `lowlevel=go1` first unless they choose a low level themselves."""
    return list(overrides) if any(o.startswith("lowlevel=") for o in overrides) else ["lowlevel=go1", *overrides]
