"""What a plan must satisfy before it becomes a robot program: it was made for this robot and station, and every
waypoint, every point the timed motion passes between them and the motion's speeds, accelerations and jerks lie
within the robot's limits; the written program, parsed back, is the plan."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..physics.trajectory import Trajectory, plan_fingerprint
from ..robots.config import RobotConfig
from ..robots.joint_limits import LIMIT_TOL, check_within_limits, within_limits
from ..robots.time_law import SegmentMotion
from .programs import TimedPath, parse

# [s] spacing of the interpolated points checked: a robot controller's interpolation period (ABB 4 ms, KUKA 12 ms)
SAMPLE_PERIOD = 0.004
# relative slack on the speed, acceleration and jerk limits: the time law drives the slowest joint exactly at its
# limit, and the scalar profile's rounding may put it a few ulps above
RATE_TOL = 1e-6
# [rad] a parsed-back joint value this far from the plan's is a writer or parser fault, not rounding (1e-7 deg)
ROUND_TRIP_TOL = 1e-6
# [s] a written segment time this much shorter than the time law's minimum is a violation, not rounding (programs
# carry times to 1e-6 s; a segment's time is the difference of two rounded times)
TIME_TOL = 2e-6


@dataclass(frozen=True)
class ProgramCheck:
    """What the checks measured: the closest any waypoint comes to a joint limit, the largest speed, acceleration
    and jerk of any joint as a fraction of the robot's rated limits, and the cycle time."""

    waypoints: int
    cycle_time: float
    speed_fraction: float
    limit_margin_deg: float
    limit_margin_at: tuple[int, int]  # (waypoint, joint index)
    peak_ratio: dict  # "velocity" | "acceleration" | "jerk" -> (fraction of the rated limit, segment, joint index)
    interpolated_points: int
    identity: str

    def summary(self) -> dict:
        return {"waypoints": self.waypoints, "cycle_time_s": round(self.cycle_time, 6),
                "speed_fraction": self.speed_fraction,
                "limit_margin_deg": round(self.limit_margin_deg, 6),
                "limit_margin_at": {"waypoint": self.limit_margin_at[0], "joint": self.limit_margin_at[1] + 1},
                **{f"peak_{k}_of_limit": {"ratio": round(r, 6), "segment": s, "joint": j + 1}
                   for k, (r, s, j) in self.peak_ratio.items()},
                "interpolated_points_checked": self.interpolated_points, "identity": self.identity}


def resolve_robot(meta: dict, config, robot: int | None) -> int:
    """The robot index the plan is exported for: ``robot`` if given, else the one the plan's meta names (by name,
    ``robot_name``, or by index); a plan naming a robot the station does not have is refused."""
    names = [r.name for r in config.robots]
    if robot is not None:
        if not 0 <= robot < len(names):
            raise ConfigError("--robot", f"robot index {robot} does not exist: station {config.name!r} has "
                                         f"{len(names)} robot(s) (0..{len(names) - 1})")
        return robot
    named = meta.get("robot_name", meta.get("robot"))
    if named is None:
        if len(names) == 1:
            return 0
        raise ConfigError("--robot", f"the plan names no robot and station {config.name!r} has {len(names)}: "
                                     f"give --robot (0..{len(names) - 1})")
    if isinstance(named, str) and named in names:
        return names.index(named)
    if isinstance(named, int) and not isinstance(named, bool) and 0 <= named < len(names):
        return named
    raise ConfigError("plan.robot", f"the plan is for robot {named!r}, which station {config.name!r} does not "
                                    f"have (robots {names})")


def check_identity(meta: dict, config, robot: int, station_named: bool, load_station) -> str:
    """Refuse a plan made for another robot or station than ``config``'s robot ``robot``: compared by the
    fingerprint the plan stores, else by that of the station its meta names as that station is now. A plan that
    names no station is taken for the one named on the command line (``station_named``), or refused. Returns how
    the identity was established (for the dry-run summary)."""
    actual = plan_fingerprint(config, robot)
    stored = meta.get("fingerprint")
    how = "fingerprint stored in the plan matches"
    if stored is None and meta.get("station"):
        try:
            planned_on = load_station(str(meta["station"]))
        except ConfigError as exc:
            raise ConfigError("plan.station", f"the plan stores no fingerprint and its station "
                                              f"{meta['station']!r} cannot be loaded to compare: {exc}") from None
        stored = plan_fingerprint(planned_on, resolve_robot(meta, planned_on, None))
        how = f"no fingerprint stored: compared with station {meta['station']!r} as it is now"
    elif stored is None:
        if not station_named:
            raise ConfigError("--station", "the plan names neither its station nor its robot (no fingerprint): give "
                                           "--station (and --robot) to say which robot it is for")
        return "no fingerprint or station stored: taken for the station and robot named on the command line"
    if not isinstance(stored, dict) or not all(isinstance(stored.get(k), str) for k in ("station", "robot")):
        raise ConfigError("plan.fingerprint", f"expected {{station: hash, robot: hash, ...}}, got {stored!r}")
    differ = [k for k in ("robot", "station") if stored[k] != actual[k]]
    if differ:
        raise ConfigError("plan", f"made for robot {stored.get('robot_name', '?')!r} of station "
                                  f"{stored.get('station_name', '?')!r}, not for robot {actual['robot_name']!r} of "
                                  f"station {actual['station_name']!r}: the {' and the '.join(differ)} differ "
                                  f"(fingerprint {', '.join(f'{k} {stored[k]} != {actual[k]}' for k in differ)}); "
                                  f"export it for the station and robot it was planned on, or plan again")
    return how


def check_program(traj: Trajectory, model: RobotConfig, speed_fraction: float, owner: str = "",
                  identity: str = "") -> ProgramCheck:
    """Refuse (ConfigError naming the waypoint or segment, the joint and the value) a plan whose waypoints or
    interpolated points leave ``model``'s joint limits, or whose timed motion at ``speed_fraction`` of the rated
    joint speeds exceeds any joint's rated velocity, acceleration or jerk; else what was measured."""
    f = speed_fraction
    if isinstance(f, bool) or not isinstance(f, (int, float)) or not math.isfinite(f) or not 0 < f <= 1:
        raise ConfigError("speed_fraction", f"{f!r} is not in (0, 1]: a program runs at most at the robot's rated "
                                            f"joint speeds")
    limits = np.array(model.joint_limits_rad, dtype=float)
    q = traj.waypoints
    inside = within_limits(q, limits)
    if not inside.all():
        k = int(np.flatnonzero(~inside)[0])
        check_within_limits(q[k], limits, f"plan.waypoints[{k}]", digits=4, owner=owner)
    rated = model.joint_motion_limits
    timed = rated.at_speed(f)
    dq = np.diff(q, axis=0)
    motions = [SegmentMotion(d, timed) for d in dq]
    peaks = {}
    # the timed motion measured against the robot's own limits (the time law is to keep within them; this proves it)
    for kind, law, allowed in (("velocity", "peak_rate", rated.velocity),
                               ("acceleration", "peak_acceleration", rated.acceleration),
                               ("jerk", "peak_jerk", rated.jerk)):
        per_joint = np.array([getattr(m, law) for m in motions])[:, None] * np.abs(dq)  # (K-1, 6)
        over = per_joint > allowed * (1 + RATE_TOL)
        if over.any():
            k, j = (int(x) for x in np.argwhere(over)[0])
            unit = {"velocity": "deg/s", "acceleration": "deg/s^2", "jerk": "deg/s^3"}[kind]
            raise ConfigError(f"plan.segments[{k}][{j}]",
                              f"joint {j + 1} moving from waypoint {k} to {k + 1} reaches "
                              f"{np.degrees(per_joint[k, j]):.4g} {unit}, above its {kind} limit "
                              f"{np.degrees(allowed[j]):.4g} {unit}{owner}")
        ratio = per_joint / allowed
        k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        peaks[kind] = (float(ratio[k, j]), int(k), int(j))
    n_points = 0
    for k, (m, a, d) in enumerate(zip(motions, q[:-1], dq)):
        t = np.append(np.arange(0.0, m.duration, SAMPLE_PERIOD), m.duration)
        frac, _ = m.at(t)
        points = a + frac[:, None] * d
        n_points += len(points)
        ok = within_limits(points, limits)
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            check_within_limits(points[i], limits, f"plan.segments[{k}]", digits=4,
                                owner=f"{owner}, at {t[i]:.3f} s of the move from waypoint {k} to {k + 1}")
    margin = np.minimum(q - limits[:, 0], limits[:, 1] - q)
    k, j = np.unravel_index(int(np.argmin(margin)), margin.shape)
    cycle = float(sum(m.duration for m in motions))
    return ProgramCheck(len(q), cycle, float(f), float(np.degrees(margin[k, j])), (int(k), int(j)), peaks,
                        n_points, identity)


def check_written(text: str, fmt: str, path: TimedPath, model: RobotConfig) -> None:
    """Parse the written program back: the joints are the plan's within ROUND_TRIP_TOL, they are within the
    limits as written, and no segment is given less time than the time law needs for it (formats with times)."""
    axes, times = parse(text, fmt)
    joints = model.from_controller(axes)
    planned = model.from_controller(path.joints)
    if joints.shape != planned.shape:
        raise ConfigError("export", f"the written {fmt} program holds {len(joints)} waypoints, the plan "
                                    f"{len(planned)}: not written")
    err = np.abs(joints - planned)
    if err.max() > ROUND_TRIP_TOL:
        k, j = np.unravel_index(int(np.argmax(err)), err.shape)
        raise ConfigError(f"export.waypoints[{k}][{j}]", f"the written {fmt} program differs from the plan by "
                                                         f"{err[k, j]:.3g} rad: not written")
    limits = np.array(model.joint_limits_rad, dtype=float)
    # rounding to DIGITS decimals of a degree may put a waypoint on its limit a hair outside: as written, the
    # controller sees it within the rounding
    widened = limits + np.array([-1, 1]) * max(ROUND_TRIP_TOL - LIMIT_TOL, 0.0)
    inside = within_limits(joints, widened)
    if not inside.all():
        k = int(np.flatnonzero(~inside)[0])
        check_within_limits(joints[k], widened, f"export.waypoints[{k}]", digits=4)
    if times is None:
        return
    need = np.array([SegmentMotion(d, model.joint_motion_limits.at_speed(path.speed_fraction)).duration
                     for d in np.diff(joints, axis=0)])
    short = np.diff(times) < need - TIME_TOL
    if short.any():
        k = int(np.flatnonzero(short)[0])
        raise ConfigError(f"export.segments[{k}]", f"the written {fmt} program gives the move from waypoint {k} to "
                                                   f"{k + 1} {np.diff(times)[k]:.6f} s, less than the "
                                                   f"{need[k]:.6f} s the joint limits allow: not written")
