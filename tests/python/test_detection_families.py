"""Guards on the recommended presets' behaviour on held-out scenario families
(docs/families.md): small seeded Monte Carlos that fail when a change makes a noise change or
normal operation raise MPM alarms, or when detection of held-out channel changes falls. Runs
are deterministic (family, seed); the bounds leave a
binomial margin over the measured counts, so they fail on a real regression, not on luck:
for a detector with a 5 % false MPM alarm rate, P(3 or more of 12) = 2 %."""

from mpmpp.family_study import run_family_seed


def detected(runs, preset):
    return sum(bool(r["presets"][preset]["detected"]) for r in runs)


def false_mpm(runs, preset):
    return sum(r["presets"][preset]["false_mpm"] for r in runs)


def test_siso_no_mpm_alarm_in_held_out_control_runs():
    runs = [run_family_seed(name, seed, configs={"siso": "siso"}, effect=effect)
            for name, effect in (("pid_siso_slow", "none"), ("pid_siso_slow", "noise_change"),
                                 ("mpc_siso_fast", "none"))
            for seed in range(4)]
    assert all(r["presets"]["siso"]["refused"] is None for r in runs)
    # Measured: 1 of 12, an mpc_siso_fast no-change run (seed 1: 1-2 s sampling with outliers
    # and step/ramp disturbances, the residual test's known weakness, docs/families.md; 0 of 12
    # with single windows at level 0.001, the preset before pooled windows); pid_siso_slow 0 of 8.
    assert false_mpm([r for r in runs if r["family"] == "pid_siso_slow"], "siso") == 0
    assert false_mpm(runs, "siso") <= 3
    # A noise change alone is not a model-plant mismatch (measured: 0 of 4).
    assert false_mpm([r for r in runs if r["expect"]["effect"] == "noise_change"], "siso") == 0


def test_mimo_few_mpm_alarms_in_held_out_noise_change_runs():
    runs = [run_family_seed("mpc_3x3_move_limits", seed, configs={"mimo": "mimo"}, effect="noise_change")
            for seed in range(4)]
    assert all(r["presets"]["mimo"]["refused"] is None for r in runs)
    # Measured: 0 of 4 (1 of 4 before the model as reference: seed 0, G[y1 <- u1] from 9.0 h,
    # 2.5 h before the noise change).
    assert false_mpm(runs, "mimo") <= 1


def test_siso_detects_held_out_gain_and_time_constant_changes():
    """Detection is guarded at what the `siso` preset achieves, not at the issue's 95 %: 42 of
    48 measured (mpc_siso_fast 24/24, pid_siso_slow 18/24; seeds 0-11, 2026-11-29, with the
    whitening at the disturbance's order; 38 of 48 with AR(9), 37 before the model as
    reference). The bound is the 1 % quantile of Binomial(48, 42/48);
    false MPM alarms (before the change) at most what a 5 % false-alarm detector exceeds with
    probability 2 %."""
    runs = [run_family_seed(name, seed, configs={"siso": "siso"}, effect=effect)
            for name in ("mpc_siso_fast", "pid_siso_slow") for effect in ("gain", "time_constant")
            for seed in range(12)]
    assert all(r["presets"]["siso"]["refused"] is None for r in runs)
    assert detected(runs, "siso") >= 36
    assert false_mpm(runs, "siso") <= 6   # measured 0


def test_mimo_detects_held_out_gain_changes():
    """The `mimo` preset on gain changes of held-out families: 11 of 20 measured
    (multi_pi_2x2 10/12, mpc_3x3_move_limits 1/8, binding move limits leave little excitation;
    2026-11-29, with the whitening at the disturbance's order; 13 of 20 with AR(18), 3/8 on the
    3x3, and 11 of 20 before the model as reference). Bound: the 1 % quantile of
    Binomial(20, 13/20), kept from the measurement before (6 for 11/20); false MPM alarms as
    above."""
    runs = [run_family_seed(name, seed, configs={"mimo": "mimo"}, effect="gain")
            for name, seeds in (("multi_pi_2x2", range(12)), ("mpc_3x3_move_limits", range(8)))
            for seed in seeds]
    assert all(r["presets"]["mimo"]["refused"] is None for r in runs)
    assert detected(runs, "mimo") >= 8
    assert false_mpm(runs, "mimo") <= 3   # measured 0


def test_siso_runs_on_short_held_out_records_without_false_alarms():
    """pi_siso_short (2-8 h records at 1-5 s) was refused in 19 of 20 runs before detect fitted
    its durations to short records (docs/detection.md "Short records"). Seeds 0-11 of each
    effect (2026-11-29, with the whitening at the disturbance's order): none refused; false MPM
    alarms 0 of 36; gain and time-constant changes detected 13 of 24 (1.2-3.6 h of data after the
    change; 11 of 24 with AR(9), 8 before the model as reference). Bounds: detection at the 1 %
    quantile of Binomial(24, 13/24); false MPM alarms at
    most what a 5 % false-alarm detector exceeds with probability 3 % in 36 runs."""
    runs = [run_family_seed("pi_siso_short", seed, configs={"siso": "siso"}, effect=effect)
            for effect in ("none", "gain", "time_constant") for seed in range(12)]
    assert all(r["presets"]["siso"]["refused"] is None for r in runs)
    assert detected([r for r in runs if r["expect"]["effect"] != "none"], "siso") >= 7
    assert false_mpm(runs, "siso") <= 4


def test_the_noise_alarm_check_names_no_process_change_in_noise_change_runs():
    """Noise-change control runs whose noise alarm no MPM alarm explains (held-out pid_siso_slow,
    tuning mpc_siso_controls; seeds of the study's run at 340-359): the second look by diagnose
    (mpmpp.noise_alarm_check) must not turn the disturbance change into a process finding.
    Measured: 0 of 25 such control runs over seeds 340-379, these five among them."""
    runs = [run_family_seed(name, seed, configs={"siso": "siso"})
            for name, seed in (("pid_siso_slow", 342), ("pid_siso_slow", 346), ("pid_siso_slow", 353),
                               ("mpc_siso_controls", 352), ("mpc_siso_controls", 354))]
    assert all(r["expect"]["effect"] == "noise_change" for r in runs)
    assert all(r["presets"]["siso"]["checks"] == 1 for r in runs)
    assert not any(r["presets"]["siso"]["check_false"] for r in runs)


def test_mimo_detects_held_out_missing_couplings():
    """A coupling that appears where the model has none alarms on its own channel (the presets'
    absent channels, docs/detection.md "Absent channels"): 10 of 16 measured (multi_pi_2x2 6/8,
    mpc_3x3_move_limits 4/8; seeds 0-7, 2026-11-29, with the whitening at the disturbance's
    order; 10 of 16 with AR(18) too, 7/8 and 3/8; 0 of 16 without absent channels). Bound: the
    1 % quantile of Binomial(16, 10/16); no MPM alarm before the change (measured 0)."""
    runs = [run_family_seed(name, seed, configs={"mimo": "mimo"}, effect="missing_coupling")
            for name in ("multi_pi_2x2", "mpc_3x3_move_limits") for seed in range(8)]
    assert all(r["presets"]["mimo"]["refused"] is None for r in runs)
    assert detected(runs, "mimo") >= 5
    assert false_mpm(runs, "mimo") <= 2
