"""Physics of the virtual robot: systematic errors, consistency between the single robot and the
batch kernel, stalls, counters."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.errors import SimError
from odolab.core.params import PRESETS
from odolab.core.trials import TrialStatus
from odolab.sim.physics import TrueParams, VirtualRobot
from odolab.sim.presets import TRUTH_PRESETS
from odolab.sim.protocols import builtin_protocols, load_protocol, parse_protocol, run_protocol

NOM = PRESETS["jaguar-lite"]


def _proto(*sets: dict[str, object], **head: object) -> object:
    return parse_protocol(
        {"protocol": {"campaign": "t", **head}, "trials": list(sets)}, "test.toml"
    )


@pytest.mark.parametrize("name", sorted(builtin_protocols()))
def test_ideal_truth_predicted_equals_true(name: str) -> None:
    trials = run_protocol(load_protocol(name), TRUTH_PRESETS["ideal"], NOM, seed=3)
    assert trials
    for t in trials:
        assert t.true is not None
        assert abs(t.predicted.x - t.true.x) < 1e-9
        assert abs(t.predicted.y - t.true.y) < 1e-9
        assert abs(t.predicted.heading - t.true.heading) < 1e-9


@given(st.floats(0.7, 1.3), st.sampled_from([1.0, 2.5, 4.0]), st.booleans())
def test_radius_error_gives_distance_ratio(scale: float, dist: float, reverse: bool) -> None:
    r = NOM.left_wheel_radius * scale
    truth = TrueParams.from_nominal(
        NOM,
        left_radius_forward=r,
        left_radius_reverse=r,
        right_radius_forward=r,
        right_radius_reverse=r,
    )
    proto = _proto(
        {
            "motion": "translation",
            "distance": dist,
            "direction": "reverse" if reverse else "forward",
        }
    )
    (t,) = run_protocol(proto, truth, NOM)  # type: ignore[arg-type]
    assert t.true is not None
    assert t.true.x / t.predicted.x == pytest.approx(scale, abs=1e-12)
    assert abs(t.true.y) < 1e-12


@given(st.floats(0.4, 0.9), st.floats(0.5, 20.0))
def test_track_error_gives_rotation_ratio(track: float, turns_pi: float) -> None:
    truth = TrueParams.from_nominal(NOM, track_width=track)
    proto = _proto({"motion": "rotation", "angle_pi": turns_pi})
    (t,) = run_protocol(proto, truth, NOM)  # type: ignore[arg-type]
    assert t.true is not None
    assert t.true.heading / t.predicted.heading == pytest.approx(NOM.track_width / track, rel=1e-12)
    assert math.hypot(t.true.x, t.true.y) < 1e-12


def test_per_direction_radius_drift_forward_and_reverse() -> None:
    # left track bigger forward: the robot curves right (clockwise) by (rl - rr) s / b
    truth = TrueParams.from_nominal(NOM, left_radius_forward=NOM.left_wheel_radius * 1.02)
    proto = _proto(
        {"motion": "translation", "distance": 2.0, "direction": "forward"},
        {"motion": "translation", "distance": 2.0, "direction": "reverse"},
    )
    fwd, rev = run_protocol(proto, truth, NOM)  # type: ignore[arg-type]
    assert fwd.true is not None and rev.true is not None
    s = fwd.predicted.x
    phi = -(0.02 * s) / NOM.track_width
    length = s * 1.01
    assert fwd.true.heading == pytest.approx(phi, rel=1e-9)
    # exact circular arc: chord of length L sin(phi/2)/(phi/2) at angle phi/2
    chord = length * math.sin(phi / 2) / (phi / 2)
    assert fwd.true.x == pytest.approx(chord * math.cos(phi / 2), rel=1e-9)
    assert fwd.true.y == pytest.approx(chord * math.sin(phi / 2), rel=1e-9)
    assert rev.true.heading == 0.0 and rev.true.x == pytest.approx(rev.predicted.x, abs=1e-12)


def test_speed_slip_and_stop_slide_by_hand() -> None:
    proto = _proto({"motion": "translation", "distance": 1.0, "speed": 0.5})
    (t,) = run_protocol(proto, TrueParams.from_nominal(NOM, speed_slip=0.1), NOM)  # type: ignore[arg-type]
    assert t.true is not None
    # all full steps at 0.5 m/s lose 5 %; the last, shorter step loses less
    assert 0.95 * t.predicted.x < t.true.x < 0.95 * t.predicted.x + 0.005
    (t,) = run_protocol(proto, TrueParams.from_nominal(NOM, stop_slide=0.2), NOM)  # type: ignore[arg-type]
    assert t.true is not None
    assert t.true.x - t.predicted.x == pytest.approx(0.2 * 0.5**2, abs=1e-12)


def test_virtual_robot_matches_batch_without_noise() -> None:
    truth = TRUTH_PRESETS["jaguar-lab"].noiseless.with_(stop_slide=0.05, speed_slip=0.02)
    mpt = NOM.left_metres_per_tick
    steps, ticks = 400, 600  # 1.5 ticks per 10 ms step: the wheels land exactly on the count
    v = ticks * mpt / (steps * 0.01)
    proto = _proto({"motion": "translation", "distance": ticks * mpt - 1e-7, "speed": v})
    (t,) = run_protocol(proto, truth, NOM)  # type: ignore[arg-type]
    robot = VirtualRobot(truth, NOM, seed=1, dt=0.01)
    c0 = robot.encoder_counts()
    robot.set_wheel_speeds(v, v)
    robot.advance(steps * 0.01)
    robot.set_wheel_speeds(0.0, 0.0)
    pose = robot.true_pose
    assert t.true is not None
    assert (pose.x, pose.y, pose.heading) == pytest.approx(
        (t.true.x, t.true.y, t.true.heading), abs=1e-9
    )
    c1 = robot.encoder_counts()
    m = NOM.encoder_modulus
    assert m is not None
    assert ((c1[0] - c0[0]) % m, (c1[1] - c0[1]) % m) == (ticks, ticks)
    assert robot.time == pytest.approx(4.0)


def test_virtual_robot_matches_batch_statistically() -> None:
    truth = TrueParams.from_nominal(NOM, k_left=1e-3, k_right=2e-3, k_scrub=0.05, track_sigma=0.03)
    angle = 2 * math.pi
    proto = _proto({"motion": "rotation", "angle": angle, "repeats": 3000, "speed": 0.4})
    trials = run_protocol(proto, truth, NOM, seed=5)  # type: ignore[arg-type]
    batch = np.array([t.true.heading for t in trials if t.true is not None])
    single = []
    robot = VirtualRobot(truth, NOM, seed=9, dt=0.01)
    duration = angle * NOM.track_width / 2 / 0.4
    for _ in range(400):
        robot.reset()
        robot.set_wheel_speeds(-0.4, 0.4)
        robot.advance(duration)
        robot.set_wheel_speeds(0.0, 0.0)
        single.append(robot.true_pose.heading)
    var_b, var_s = batch.var(ddof=1), np.var(single, ddof=1)
    assert var_s / var_b == pytest.approx(1.0, abs=0.3)
    assert np.mean(single) == pytest.approx(batch.mean(), abs=4 * math.sqrt(var_b / 400))


def test_stall_on_grass_and_pivot() -> None:
    truth = TRUTH_PRESETS["jaguar-lab"]
    robot = VirtualRobot(truth, NOM, "grass", seed=2)
    c0, p0 = robot.encoder_counts(), robot.true_pose
    robot.set_wheel_speeds(-0.3, 0.3)
    robot.advance(2.0)
    assert robot.stalled
    assert robot.encoder_counts() == c0
    assert robot.true_pose[1:] == p0[1:]
    robot.set_wheel_speeds(0.0, 0.3)  # pivot on the left track
    robot.advance(2.0)
    assert not robot.stalled
    assert robot.encoder_counts()[0] == c0[0] and robot.encoder_counts()[1] != c0[1]
    assert robot.true_pose.heading - p0.heading > 0.5
    trials = run_protocol(load_protocol("rotation"), truth, NOM, terrain="concrete")
    assert all(t.status is TrialStatus.EXCLUDED for t in trials)
    assert all(t.predicted.heading == 0.0 for t in trials)
    tile = run_protocol(load_protocol("rotation"), truth, NOM, terrain="tile")
    assert all(t.status is TrialStatus.MEASURED for t in tile)


def test_counters_wrap_and_seed_reproducible() -> None:
    proto = load_protocol("rotation")
    a = run_protocol(proto, TRUTH_PRESETS["jaguar-lab"], NOM, seed=11)
    b = run_protocol(proto, TRUTH_PRESETS["jaguar-lab"], NOM, seed=11)
    c = run_protocol(proto, TRUTH_PRESETS["jaguar-lab"], NOM, seed=12)
    assert [t.true for t in a] == [t.true for t in b]
    assert [t.measured for t in a] == [t.measured for t in b]
    assert [t.true for t in a] != [t.true for t in c]
    m = NOM.encoder_modulus
    assert m is not None
    wrapped = 0
    for t in a:
        log = t.encoder_log
        assert log is not None and log.modulus == m
        assert log.left_ticks.min() >= 0 and log.right_ticks.max() < m
        wrapped += int((np.abs(np.diff(log.right_ticks)) > m // 2).any())
        assert log.t[1] - log.t[0] == pytest.approx(0.05)
    assert wrapped > 0  # some 20 pi rotations cross the counter's wrap
    assert len({t.trial_id for t in a}) == len(a)
    assert a[0].trial_id == "rotation-indoor-000"


def test_bad_virtual_robot_input() -> None:
    with pytest.raises(SimError, match="dt"):
        VirtualRobot(TRUTH_PRESETS["ideal"], NOM, dt=0.0)
    robot = VirtualRobot(TRUTH_PRESETS["ideal"], NOM)
    with pytest.raises(SimError, match="duration"):
        robot.advance(-1.0)
    with pytest.raises(SimError, match="unknown terrain 'mud'"):
        VirtualRobot(TRUTH_PRESETS["ideal"], NOM, "mud")
    with pytest.raises(SimError, match="track_width"):
        TrueParams.from_nominal(NOM, track_width=-1.0)


def test_the_control_cycle_kernel_takes_no_generator() -> None:
    """The kernel each control cycle calls gets its noise as an array. A Generator passed into
    compiled code is unboxed by Python code, where an exception from a signal handler (Ctrl-C,
    SIGTERM) crashed numba: the board process segfaulted once in 60 runs of the safety suite."""
    from numba.core import types

    from odolab.sim import _physics_jit as physics  # the compiled physics (VirtualRobot's default)

    robot = VirtualRobot(TRUTH_PRESETS["jaguar-lab"], NOM, "tile", seed=3)
    robot.set_wheel_speeds(0.4, 0.5)
    robot.advance(0.0125)  # whole steps and a shorter last one
    assert physics._advance.signatures
    for signature in physics._advance.signatures:
        assert not any(isinstance(t, types.NumPyRandomGeneratorType) for t in signature)


def test_noise_draws_follow_the_generator_in_order() -> None:
    """The cycle kernel uses the plant's Generator's draws in its own order, skipping none and
    drawing none while stalled: two plants with one seed, one advanced in many short calls and
    one in a few long ones, both stalled in between, end in the same place."""
    a = VirtualRobot(TRUTH_PRESETS["jaguar-lab"], NOM, "grass", seed=9)
    b = VirtualRobot(TRUTH_PRESETS["jaguar-lab"], NOM, "grass", seed=9)
    for speeds, seconds in (((0.5, 0.5), 0.4), ((0.3, -0.3), 0.2), ((0.2, 0.6), 0.32)):
        a.set_wheel_speeds(*speeds)
        b.set_wheel_speeds(*speeds)
        for _ in range(40):
            a.advance(seconds / 40)
        b.advance(seconds)
    assert a.stalled is False
    np.testing.assert_allclose(np.array(a.true_pose), np.array(b.true_pose), rtol=0, atol=1e-12)
    # and the noise is really there: another seed ends elsewhere
    c = VirtualRobot(TRUTH_PRESETS["jaguar-lab"], NOM, "grass", seed=10)
    for speeds, seconds in (((0.5, 0.5), 0.4), ((0.3, -0.3), 0.2), ((0.2, 0.6), 0.32)):
        c.set_wheel_speeds(*speeds)
        c.advance(seconds)
    assert abs(c.true_pose.x - b.true_pose.x) + abs(c.true_pose.y - b.true_pose.y) > 1e-9


def test_ctrl_c_and_sigterm_wait_for_the_batch_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """The batch kernel takes a Generator, unboxed by Python code where an exception from a
    signal handler would crash numba: the signal acts when the kernel has returned."""
    import signal

    from odolab.sim import _physics_jit as physics  # where simulate_batch finds its kernel

    real = physics._batch
    order: list[str] = []

    def kernel(*args: object) -> None:
        signal.raise_signal(signal.SIGTERM)
        signal.raise_signal(signal.SIGINT)
        order.append("kernel started")
        real(*args)
        order.append("kernel done")

    monkeypatch.setattr(physics, "_batch", kernel)
    int_handler = signal.getsignal(signal.SIGINT)
    old_term = signal.signal(signal.SIGTERM, lambda _s, _f: order.append("SIGTERM handled"))
    try:
        proto = _proto({"motion": "translation", "distance": 0.5, "speed": 0.4})
        with pytest.raises(KeyboardInterrupt):
            run_protocol(proto, TRUTH_PRESETS["jaguar-lab"], NOM)  # type: ignore[arg-type]
        assert order == ["kernel started", "kernel done", "SIGTERM handled"]
        assert signal.getsignal(signal.SIGINT) is int_handler
    finally:
        signal.signal(signal.SIGTERM, old_term)


def test_a_second_ctrl_c_while_handlers_return_leaves_every_handler_back(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import signal

    from odolab.sim import physics

    real = signal.signal
    order: list[str] = []

    def restore_then_ctrl_c(sig: int, handler: object) -> object:
        old = real(sig, handler)  # type: ignore[arg-type]
        if sig == signal.SIGINT and handler is signal.default_int_handler:
            signal.raise_signal(signal.SIGINT)  # lands while the other handlers are not back
        return old

    old_term = real(signal.SIGTERM, lambda _s, _f: order.append("SIGTERM handled"))
    try:
        term_handler = signal.getsignal(signal.SIGTERM)
        with pytest.raises(KeyboardInterrupt), physics._signals_held():
            signal.raise_signal(signal.SIGTERM)
            monkeypatch.setattr(signal, "signal", restore_then_ctrl_c)
        monkeypatch.setattr(signal, "signal", real)
        assert signal.getsignal(signal.SIGTERM) is term_handler
        assert order == ["SIGTERM handled"]  # replayed, though Ctrl-C came too
    finally:
        real(signal.SIGTERM, old_term)


def test_a_long_advance_runs_in_blocks_with_the_same_motion() -> None:
    """advance(70 s) at 1 ms is 70,000 steps: more than one kernel call (their draws in memory
    a block at a time), the same motion as seventy 1 s advances."""
    from odolab.sim.physics import _STEPS_PER_CALL

    assert _STEPS_PER_CALL < 70_000
    a = VirtualRobot(TRUTH_PRESETS["jaguar-lab"], NOM, "tile", seed=4)
    b = VirtualRobot(TRUTH_PRESETS["jaguar-lab"], NOM, "tile", seed=4)
    for r in (a, b):
        r.set_wheel_speeds(0.3, 0.32)
    a.advance(70.0)
    for _ in range(70):
        b.advance(1.0)
    assert np.array(a.true_pose).tolist() == np.array(b.true_pose).tolist()
    assert a.encoder_counts() == b.encoder_counts()
