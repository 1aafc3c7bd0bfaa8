"""Figures and campaign results: plot functions return Figures without pyplot or a backend, draw the
signals they claim (checked against the simulator's arrays and the feature table), use the campaign's
threshold, cover any swept effect or say why not; re-simulated time series equal saved ones; reprs are short."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.campaign import CampaignResult, load_campaign, run_campaign
from ur5fault.campaign.summary import effect_sweep, severity_table, tcp_table
from ur5fault.errors import ConfigFileError, ParameterError, UnknownNameError
from ur5fault.plotting import (
    FIG3_STEM,
    FIG4_STEM,
    campaign_figures,
    drawn_and_failed,
    fig3_tcp_deviation,
    figure_stems,
    plot_campaign,
    run_figure,
    severity_figure,
)

PACKAGE = Path(__file__).resolve().parents[1] / "ur5fault"

# backlash and Coulomb friction each alone on joints 2 and 3 (zipped levels; 0 / 1 mean "absent"), 5.5 s of the
# pick-and-place (the shoulder's first torque reversal is at ~5 s); a threshold that is not the default 0.5 mm
TWO_EFFECTS = """name: two
trajectory: pick_and_place
duration_s: 5.5
base: {seed: 0, payload_kg: 2.0}
sweep:
  backlash.joint: [2, 3]
  coulomb_friction.joint: [2, 3]
zip:
  - {backlash.backlash_deg: [0.1, 0.2, 0.0, 0.0], coulomb_friction.scale: [1.0, 1.0, 2.0, 3.0]}
threshold_mm: 0.3
save_timeseries: SAVE
"""


def _campaign(folder: Path, save: bool) -> Path:
    f = folder / "two.yaml"
    f.write_text(TWO_EFFECTS.replace("SAVE", "true" if save else "false"))
    run_campaign(load_campaign(f), folder / "out", jobs=1, progress=False)
    return folder / "out"


@pytest.fixture(scope="module")
def two(tmp_path_factory) -> CampaignResult:
    """The campaign, its time series saved."""
    return CampaignResult.load(_campaign(tmp_path_factory.mktemp("two"), save=True))


@pytest.fixture(scope="module")
def run_pair():
    """A healthy run and a shoulder-backlash run, 5.5 s, straight from the simulator."""
    runs = [RunSpec("healthy", 0), RunSpec("worn", 0, (make_effect("backlash", "shoulder", backlash_deg=0.2),))]
    return Simulator().run(pick_and_place(), runs, duration_s=5.5)


def _lines(ax):
    return [line for line in ax.get_lines() if len(line.get_xdata()) > 2]


def _hlines(ax):
    return [line.get_ydata()[0] for line in ax.get_lines() if len(set(np.ravel(line.get_ydata()))) == 1
            and len(line.get_xdata()) == 2]


# ----------------------------------------------------------------------------- no backend, no pyplot
def test_library_never_picks_a_backend():
    offenders = [str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                 if "matplotlib.use(" in p.read_text() or "import matplotlib.pyplot" in p.read_text()]
    assert offenders == []


def test_figures_made_without_importing_pyplot(tmp_path):
    code = (
        "import sys, pandas as pd\n"
        "from ur5fault import Simulator, RunSpec, pick_and_place\n"
        "from ur5fault.plotting import run_figure\n"
        "res = Simulator().run(pick_and_place(), [RunSpec('r')], duration_s=0.05)\n"
        "fig = run_figure(res.to_pandas(0))\n"
        f"fig.savefig({str(tmp_path / 'r.png')!r})\n"
        "print(type(fig).__name__, 'matplotlib.pyplot' in sys.modules)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["Figure", "False"]
    assert (tmp_path / "r.png").stat().st_size > 10_000


# ----------------------------------------------------------------------------- one run
def test_run_figure_draws_the_simulated_signals(run_pair):
    res = run_pair
    fig = run_figure(res.to_pandas("worn"), twin=res.to_pandas("healthy"))
    assert isinstance(fig, Figure)
    ang, err, mis, cur, tcp = fig.axes[:5]
    q_fb, q_set = res["q_FB_rad"][1], res.q_set_rad
    np.testing.assert_allclose(_lines(ang)[3].get_ydata(), np.degrees(q_fb[:, 1]))  # J2 resolver (2nd of pair)
    np.testing.assert_allclose(_lines(err)[1].get_ydata(), np.degrees(q_set[:, 1] - q_fb[:, 1]))  # deg, as faults
    np.testing.assert_allclose(_lines(mis)[1].get_ydata(), np.degrees(res["q_M_FB_rad"][1][:, 1] / 101.0 - q_fb[:, 1]))
    np.testing.assert_allclose(_lines(cur)[1].get_ydata(), res["i_FB_A"][1][:, 1])
    dev_mm = 1e3 * np.linalg.norm(res.tcp_m[1] - res.tcp_m[0], axis=-1)
    np.testing.assert_allclose(_lines(tcp)[1].get_ydata(), dev_mm, atol=1e-12)
    assert dev_mm.max() > 1.0  # the backlash really shows (0.2 deg on the shoulder)


def test_run_figure_draws_into_given_axes_and_checks_input(run_pair):
    outer = Figure()
    axes = outer.subplots(5, 1)
    assert run_figure(run_pair.to_pandas(0), axes=axes) is outer
    with pytest.raises(ParameterError, match="axes: 2 given, run_figure draws 5 panels"):
        run_figure(run_pair.to_pandas(0), axes=axes[:2])
    with pytest.raises(ParameterError, match="time series lacks column 'q_set_rad_j1'"):
        run_figure(pd.DataFrame({"t_s": [0.0, 1.0]}))
    # a campaign's run file (one row of features, given to `ur5fault show` as a file): what to give instead
    with pytest.raises(ParameterError, match=r"a campaign's run file .* give `ur5fault show r0123 --campaign DIR`"):
        run_figure(pd.DataFrame({"run_id": ["r0123"], "tcp_dev_max_mm": [0.1]}))


# ----------------------------------------------------------------------------- campaigns
def test_resimulated_time_series_equal_saved_ones(tmp_path, two, caplog):
    shutil.copy(two.out / "features.parquet", tmp_path)  # the same campaign without its time series,
    manifest = json.loads((two.out / "manifest.json").read_text())  # as if run by another version
    (tmp_path / "manifest.json").write_text(json.dumps({**manifest, "ur5fault_version": "0.0.1"}))
    bare = CampaignResult.load(tmp_path)
    worn = two.features[(two.features["fault"] == "backlash") & (two.features["fault_joint"] == 2)]["run_id"]
    ids = list(worn)  # their twin is simulated with them, not returned
    with caplog.at_level("INFO", logger="ur5fault"):
        resim = bare.time_series(ids)
    assert list(resim) == ids and not (tmp_path / "timeseries").exists()
    assert "was run with ur5fault 0.0.1" in caplog.text and f"re-simulating {len(ids)} run(s)" in caplog.text
    for r in ids:
        pd.testing.assert_frame_equal(resim[r], pd.read_parquet(two.out / "timeseries" / f"{r}.parquet"))


def test_fig3_uses_campaign_threshold_and_matches_features(two):
    fig = fig3_tcp_deviation(two)
    ax = fig.axes[0]
    assert _hlines(ax) == [pytest.approx(0.3)]  # manifest threshold_mm, not the default 0.5
    rows = two.features[(two.features["fault"] == "backlash") & np.isclose(two.features["backlash_deg"], 0.1)]
    by_joint = {int(r.fault_joint): r.tcp_dev_max_mm for r in rows.itertuples()}
    curves = _lines(ax)
    assert [c.get_label() for c in curves] == ["J2 shoulder_lift_joint", "J3 elbow_joint"]
    for curve, j in zip(curves, (2, 3)):  # features were computed from the arrays; the figure from the files
        assert np.nanmax(curve.get_ydata()) == pytest.approx(by_joint[j], rel=1e-9, abs=1e-12)


def test_every_swept_effect_gets_a_severity_figure(two):
    figs, messages = campaign_figures(two)
    assert messages == []
    assert set(figs) == {"fig3_tcp_deviation_alpha0.1", "fig4_shoulder_current", "severity_backlash_tcp_dev_max_mm",
                         "heatmap_backlash_tcp_dev_max_mm", "severity_coulomb_friction_tcp_dev_max_mm",
                         "heatmap_coulomb_friction_tcp_dev_max_mm"}
    ax = figs["severity_coulomb_friction_tcp_dev_max_mm"].axes[0]
    df = two.features[two.features["fault"] == "coulomb_friction"]
    # the documented size: the fault_size column when the table has one, else the swept parameter's column
    size = "fault_size" if "fault_size" in df.columns else "coulomb_friction_scale"
    assert ax.get_xlabel() == ("scale [-]" if size != "fault_size" else "coulomb_friction size [fraction]")
    joints = set()
    for line in ax.get_lines():
        if line.get_label().startswith("J"):
            j = int(line.get_label()[1])
            joints.add(j)
            sub = df[df["fault_joint"] == j].sort_values(size)
            np.testing.assert_array_equal(line.get_xdata(), sub[size])
            np.testing.assert_array_equal(line.get_ydata(), sub["tcp_dev_max_mm"])
    assert joints == {2, 3}
    assert 0.3 in _hlines(ax)


def test_per_joint_feature_read_on_the_faulty_joint(two):
    sweep = effect_sweep(two.features, "coulomb_friction", ["scale"])
    table = severity_table(sweep, "current_spike_max_A")
    df = two.features[two.features["fault"] == "coulomb_friction"]
    for j in (2, 3):
        sub = df[df["fault_joint"] == j].set_index("coulomb_friction_scale")[f"current_spike_max_A_j{j}"]
        np.testing.assert_array_equal(table.loc[f"{j} {('shoulder_lift_joint', 'elbow_joint')[j - 2]}"], sub)
    fig = severity_figure(sweep, "current_spike_max_A")
    assert fig.axes[0].get_ylabel() == "largest current spike at a torque reversal [A] of the faulty joint"
    assert fig.axes[0].get_title() == "largest current spike at a torque reversal of the faulty joint against " \
                                      "coulomb_friction size"
    with pytest.raises(UnknownNameError, match="unknown feature 'nope'; valid: .*current_spike_max_A"):
        severity_table(sweep, "nope")
    # a label, condition or timing column of the table is not a health feature (fault_joint drew flat lines 1..6)
    for column in ("fault_joint", "wall_s_batch", "backlash_deg", "payload_kg"):
        with pytest.raises(UnknownNameError, match=f"unknown feature '{column}'"):
            severity_table(sweep, column)


def test_angle_features_are_drawn_in_degrees(two):
    """Angles a person reads are in degrees (docs/outputs.md "Units"); the feature table keeps radians."""
    sweep = effect_sweep(two.features, "backlash", ["backlash_deg"])
    df = two.features[two.features["fault"] == "backlash"]
    ax = severity_figure(sweep, "enc_mismatch_p2p_rad").axes[0]
    assert ax.get_ylabel() == "encoder mismatch, peak to peak [deg] of the faulty joint"
    for line in _lines(ax):
        j = int(line.get_label()[1])
        sub = df[df["fault_joint"] == j].sort_values("backlash_deg")
        np.testing.assert_allclose(line.get_ydata(), sub[f"enc_mismatch_p2p_rad_j{j}"] * 180.0 / np.pi, rtol=1e-12)


def test_tcp_table_is_the_backlash_pivot(two):
    df = two.features
    bl = df[(df["fault"] == "backlash") & (df["status"] == "ok")]
    expected = bl.pivot_table(index="fault_joint", columns="backlash_deg", values="tcp_dev_max_mm", aggfunc="max")
    got = tcp_table(df)
    np.testing.assert_array_equal(got[[0.1, 0.2]].to_numpy(), expected.to_numpy())
    assert list(got.index) == ["2 shoulder_lift_joint", "3 elbow_joint"] and (got[0.0] == 0.0).all()


def test_effects_without_a_figure_get_a_message(tmp_path):
    feats = pd.DataFrame({
        "run_id": ["a", "b", "c", "h"], "fault": ["payload_com", "payload_com", "torque_constant", "healthy"],
        "status": ["ok", "ok", "protective_stop", "ok"], "fault_joint": [0, 0, 2, 0],
        "payload_com_dx_m": [0.1, 0.0, np.nan, np.nan], "payload_com_dz_m": [0.0, 0.1, np.nan, np.nan],
        "torque_constant_scale": [np.nan, np.nan, 0.2, np.nan], "tcp_dev_max_mm": [1.0, 2.0, np.nan, 0.0],
    })
    manifest = {"name": "x", "threshold_mm": 0.5, "swept_keys": ["payload_com.dx_m", "payload_com.dz_m",
                                                                 "torque_constant.joint", "torque_constant.scale"]}
    figs, messages = campaign_figures(CampaignResult(tmp_path, feats, manifest))
    assert figs == {}
    assert messages == [
        "no figure for effect 'payload_com': 2 parameters swept together (dx_m, dz_m); a severity axis needs one "
        "(or a fault_size column)",
        "no figure for effect 'torque_constant': 1 run(s), none ok",
    ]


@pytest.mark.parametrize("swept_keys", [["delay.delay_ms"], []], ids=["swept", "sampled"])
def test_fault_size_column_is_preferred(tmp_path, swept_keys):
    """The size is read from fault_size (not the leftover delay_delay_ms column); a sampled campaign, whose
    manifest lists no swept effect, gets its figures from the fault labels."""
    feats = pd.DataFrame({
        "run_id": list("abcd"), "fault": ["delay"] * 3 + ["healthy"], "status": ["ok"] * 4, "fault_joint": [0] * 4,
        "fault_size": [2.0, 5.0, 10.0, 0.0], "fault_size_unit": ["ms"] * 3 + [""], "delay_delay_ms": [9.0] * 4,
        "tcp_dev_max_mm": [0.1, 0.4, 0.9, 0.0],
    })
    manifest = {"name": "x", "threshold_mm": 0.5, "swept_keys": swept_keys}
    figs, messages = campaign_figures(CampaignResult(tmp_path, feats, manifest))
    ax = figs["severity_delay_tcp_dev_max_mm"].axes[0]
    assert messages == [] and ax.get_xlabel() == "delay size [ms]"
    np.testing.assert_array_equal(_lines(ax)[0].get_xdata(), [2.0, 5.0, 10.0])


def test_signed_parameter_kept_when_sizes_would_fold(tmp_path):
    """A friction scale of 0.5 and 1.5 both have fault_size 0.5: the severity axis keeps the scale."""
    feats = pd.DataFrame({
        "run_id": list("abh"), "fault": ["viscous_friction"] * 2 + ["healthy"], "status": ["ok"] * 3,
        "fault_joint": [2, 2, 0], "fault_size": [0.5, 0.5, 0.0], "fault_size_unit": ["fraction"] * 2 + [""],
        "viscous_friction_scale": [0.5, 1.5, np.nan], "tcp_dev_max_mm": [0.2, 0.3, 0.0],
    })
    manifest = {"name": "x", "threshold_mm": 0.5, "swept_keys": ["viscous_friction.joint", "viscous_friction.scale"]}
    figs, _ = campaign_figures(CampaignResult(tmp_path, feats, manifest))
    ax = figs["severity_viscous_friction_tcp_dev_max_mm"].axes[0]
    assert ax.get_xlabel() == "scale [-]"
    np.testing.assert_array_equal(ax.get_lines()[0].get_xdata(), [0.5, 1.5])


def test_plot_and_show_commands(tmp_path, two, capsys):
    from ur5fault.cli import main

    assert main(["plot", str(two.out), "--out", str(tmp_path / "p")]) == 0
    assert len(list((tmp_path / "p").glob("*.png"))) == 6 and capsys.readouterr().out.count("wrote ") == 6
    run_id = two.features.loc[two.features["fault"] == "backlash", "run_id"].iloc[0]
    assert main(["show", run_id, "--campaign", str(two.out), "--out", str(tmp_path / "s.png")]) == 0
    assert (tmp_path / "s.png").stat().st_size > 20_000
    assert main(["show", str(two.out / "timeseries" / f"{run_id}.parquet"), "--out", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 20_000
    capsys.readouterr()
    for args, message in ((["show", "rnope", "--campaign", str(two.out)], "unknown run_id 'rnope'; valid: r"),
                          (["show", str(tmp_path / "none.parquet")], "none.parquet: no such file"),
                          (["show", "r1", "--campaign", str(tmp_path)], "no features.parquet"),
                          (["show", "r1", "--campaign", str(tmp_path / "nonexist")],
                           "nonexist: no such campaign folder"),
                          (["plot", str(two.out), "--feature", "nope"], "unknown feature 'nope'")):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert message in err and err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err


def test_show_and_plot_refuse_to_replace_an_earlier_figure_before_any_work(tmp_path, two, capsys, monkeypatch):
    """``show --out mine.png`` replaced a user's own file and ``plot`` an earlier plot's figures silently, where every
    other command refuses an earlier result unless given --replace: now one line naming the file, before reading,
    re-simulating or drawing anything; --replace writes it."""
    import ur5fault.plotting
    from ur5fault.cli import main

    def one_line_refusal(args, path):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err
        if "--out" in args:
            assert f"--out {path}: an earlier result is there; give --replace to replace it" in err, err
        else:  # the default place: said so, and --out not named as if the user had given it
            assert err == (f"ur5fault: error: {path}: an earlier result is there (the default place, as no --out "
                           "was given); give --replace to replace it, or choose another place with --out\n"), err

    run_id = two.features.loc[two.features["fault"] == "backlash", "run_id"].iloc[0]
    run = tmp_path / "r.parquet"
    shutil.copy(two.out / "timeseries" / f"{run_id}.parquet", run)
    mine = tmp_path / "mine.png"
    mine.write_text("notes\n")
    one_line_refusal(["show", str(run), "--out", str(mine)], mine)
    (tmp_path / "r.png").write_text("notes\n")  # the default place, beside the file
    one_line_refusal(["show", str(run)], tmp_path / "r.png")
    (tmp_path / "bad.parquet").write_bytes(b"not parquet")  # refused before it is read
    (tmp_path / "bad.png").write_text("notes\n")
    one_line_refusal(["show", str(tmp_path / "bad.parquet")], tmp_path / "bad.png")
    assert mine.read_text() == (tmp_path / "r.png").read_text() == "notes\n"
    capsys.readouterr()
    assert main(["show", str(run), "--out", str(mine), "--replace"]) == 0
    assert mine.read_bytes().startswith(b"\x89PNG")
    assert capsys.readouterr().out == f"replaced {mine}\n"  # as `simulate` says it

    copy = tmp_path / "c"
    shutil.copytree(two.out, copy)
    shown = copy / "plots" / f"show_{run_id}.png"
    shown.parent.mkdir()
    shown.write_text("notes\n")
    monkeypatch.setattr(CampaignResult, "time_series", lambda *a: pytest.fail("read or re-simulated"))
    one_line_refusal(["show", run_id, "--campaign", str(copy)], shown)
    monkeypatch.undo()
    assert main(["plot", str(copy)]) == 0  # a file of another name in the folder (show's) is left alone
    assert shown.read_text() == "notes\n"
    capsys.readouterr()
    monkeypatch.setattr(ur5fault.plotting, "drawn_and_failed", lambda *a, **k: pytest.fail("drawn"))
    # the paper's figures do not depend on the feature: kept; the first figure that does is refused
    first = next(s for s in ur5fault.plotting.figure_stems(CampaignResult.load(copy)) if s.startswith("severity_"))
    one_line_refusal(["plot", str(copy)], copy / "plots" / f"{first}.png")
    monkeypatch.undo()
    # another feature's figures (the help's second example): drawn, the paper's kept from the earlier plot, said so
    fig3 = copy / "plots" / "fig3_tcp_deviation_alpha0.1.png"
    before = fig3.read_bytes()
    assert main(["plot", str(copy), "--feature", "current_spike_max_A"]) == 0
    out = capsys.readouterr().out
    assert f"{fig3}: from an earlier plot, not redrawn now" in out and "severity_" in out
    assert fig3.read_bytes() == before
    assert main(["plot", str(copy), "--replace"]) == 0
    out = capsys.readouterr().out
    assert out.count("replaced ") == 6 and "wrote " not in out, out  # every figure was there: replaced, said so


def test_show_names_the_columns_it_draws_that_hold_no_finite_value(tmp_path, capsys):
    """A time series whose column is all inf or NaN was drawn with its curves silently missing: one note on stderr
    names such columns. A column finite in part (a run stopped early is NaN after its stop) is drawn as far as it goes
    and not named, and a column the figure does not draw is not named either."""
    from ur5fault.cli import main

    csv = tmp_path / "s1.csv"
    assert main(["simulate", "--duration-s", "0.05", "--quiet", "--out", str(csv)]) == 0
    df = pd.read_csv(csv)
    capsys.readouterr()
    assert main(["show", str(csv)]) == 0
    assert "note" not in capsys.readouterr().err  # every column finite
    df["q_FB_rad_j1"] = np.inf
    df.loc[len(df) // 2:, [c for c in df.columns if c.startswith("i_FB_A_")]] = np.nan  # stopped half way
    df[[c for c in df.columns if c.startswith("T_gear_Nm")][0]] = np.nan  # not drawn
    df.to_csv(csv, index=False)
    assert main(["show", str(csv), "--replace"]) == 0
    cap = capsys.readouterr()
    assert cap.err.splitlines() == ["note: no finite value in q_FB_rad_j1 (NaN or inf in every row): its curves are "
                                    "missing from the figure"], cap.err
    assert cap.out.startswith("replaced ")  # the figure of the first `show`
    from ur5fault.run_cli import _note_empty_columns

    df[[c for c in df.columns if c.startswith("q_FB_rad_")]] = np.nan  # a run stopped before its first logged sample
    df.attrs["ur5fault"] = {"status": "diverged"}
    _note_empty_columns(df, None)
    assert capsys.readouterr().err == ("note: no finite value in q_FB_rad_j1, q_FB_rad_j2, q_FB_rad_j3, q_FB_rad_j4, "
                                       "q_FB_rad_j5, q_FB_rad_j6 (NaN or inf in every row; the run's status: "
                                       "diverged): their curves are missing from the figure\n")


def test_plot_campaign_writes_png_files(tmp_path, two):
    paths = plot_campaign(two.out, plot_dir=tmp_path)
    assert len(paths) == 6 and all(p.stat().st_size > 10_000 for p in paths)
    with pytest.raises(ConfigFileError, match="no features.parquet"):
        plot_campaign(tmp_path)


# ----------------------------------------------------------------------------- reprs
def test_reprs_are_short_and_tabular(run_pair, two):
    text = repr(run_pair)
    assert len(text) < 500 and "2 run(s) x 5500 samples" in text and "worn ok [backlash on shoulder_lift_joint" in text
    assert "array" not in text and "<table" in run_pair._repr_html_()
    text = repr(two)
    assert len(text) < 400 and "9 runs (9 ok)" in text and "threshold 0.3 mm; time series saved" in text
    html = two._repr_html_()
    assert html.count("<table") == 3  # backlash, coulomb friction, acceptable backlash
    assert json.loads((two.out / "manifest.json").read_text())["threshold_mm"] == 0.3


def test_tables_carry_run_metadata_so_figures_are_titled(run_pair, two):
    worn = run_pair.to_pandas("worn")
    meta = worn.attrs["ur5fault"]
    assert meta["run_id"] == "worn" and meta["status"] == "ok"
    assert meta["effects"] == ["backlash on shoulder_lift_joint (backlash_deg=0.2)"]
    title = run_figure(worn, twin=run_pair.to_pandas("healthy"))._suptitle.get_text()
    assert title == "worn: backlash on shoulder_lift_joint (backlash_deg=0.2) (ok)"
    rid = two.features.loc[two.features["fault"] == "backlash", "run_id"].iloc[0]
    saved = pd.read_parquet(two.out / "timeseries" / f"{rid}.parquet")  # a campaign's time-series file
    assert saved.attrs["ur5fault"]["run_id"] == rid and "backlash on" in run_figure(saved)._suptitle.get_text()


def test_run_figure_of_a_pair_draws_both_deviations(run_pair):
    fig = run_figure(run_pair.to_pandas("worn"), twin=run_pair.to_pandas("healthy"))
    assert isinstance(fig, Figure) and len(fig.axes) == 5
    assert fig._suptitle.get_text().startswith("worn: backlash on shoulder_lift_joint")
    labels = [line.get_label() for line in fig.axes[4].get_lines()]
    assert labels == ["from desired TCP", "from healthy twin"]


def test_wrong_feature_gets_a_did_you_mean(two, capsys):
    from ur5fault.cli import main

    assert main(["plot", str(two.out), "--feature", "tcp_dev_max_m"]) == 2
    assert "unknown feature 'tcp_dev_max_m' (did you mean 'tcp_dev_max_mm'" in capsys.readouterr().err
    # a name with no near miss: the ~400 features were listed in one line that filled the screen; now the first
    # MAX_LISTED / 2 and how many more
    from ur5fault.errors import MAX_LISTED

    assert main(["plot", str(two.out), "--feature", "nonsense"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    names = [f"feature_{k:03d}_j1" for k in range(400)]  # a twin-residual campaign's ~400
    err = str(UnknownNameError("feature", "nonsense", names))
    assert err.endswith(f"feature_{MAX_LISTED // 2 - 1:03d}_j1, ... ({400 - MAX_LISTED // 2} more)"), err
    assert str(UnknownNameError("feature", "feature_007_j2", names)).startswith(
        "unknown feature 'feature_007_j2' (did you mean 'feature_007_j1'")  # the hint searches them all
    assert str(UnknownNameError("x", "y", names[:MAX_LISTED])).endswith(names[MAX_LISTED - 1])  # listed in full


def test_plot_default_folder_with_a_file_in_the_way(tmp_path, two, capsys):
    """``plot DIR`` writes into DIR/plots; a file of that name was a traceback at the first figure's write."""
    from ur5fault.cli import main

    copy = tmp_path / "c"
    shutil.copytree(two.out, copy)
    (copy / "plots").write_text("x")
    assert main(["plot", str(copy)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err
    assert "plots: exists and is not a folder" in err


def test_a_feature_missing_in_every_run_is_one_line_not_blank_figures(two):
    """A feature NaN in every run (the encoder mismatch of a campaign without motor encoders) drew empty axes in
    every figure and said nothing; now one line naming it, before any figure."""
    import dataclasses

    from ur5fault.errors import ConfigFileError
    from ur5fault.plotting import campaign_figures

    df = two.features.copy()
    df[[f"enc_mismatch_p2p_rad_j{j}" for j in range(1, 7)]] = np.nan
    blind = dataclasses.replace(two, features=df, manifest={**two.manifest, "motor_encoders": False})
    with pytest.raises(ConfigFileError, match=r"^enc_mismatch_p2p_rad is missing \(NaN\) in every run of .* \(the "
                                              r"campaign has motor_encoders: false\): nothing to draw"):
        campaign_figures(blind, "enc_mismatch_p2p_rad")
    assert campaign_figures(two, "enc_mismatch_p2p_rad")[0]  # with its values: drawn


def test_figures_not_redrawn_are_said_to_be_an_earlier_plots(tmp_path, two, capsys, caplog):
    """A damaged time series is simulated again (a warning names it) and Fig. 3 and Fig. 4 are redrawn; where the run
    cannot be simulated again either (here the manifest's campaign, edited by hand without its sidecar, no longer
    validates) they are not: the reason is printed once as an error (both read the same runs; it was printed twice, on
    stdout, with exit status 0), the severity figures are still drawn, the exit status is 1, and the earlier plot's
    Fig. 3 and Fig. 4 left in the folder are named as not redrawn."""
    import json

    from ur5fault.cli import main

    copy = tmp_path / "c"
    shutil.copytree(two.out, copy)
    assert main(["plot", str(copy)]) == 0
    capsys.readouterr()
    f = sorted((copy / "timeseries").glob("*.parquet"))[0]
    b = bytearray(f.read_bytes())
    b[len(b) // 2] ^= 0x01
    f.write_bytes(bytes(b))
    assert main(["plot", str(copy), "--replace"]) == 0
    cap = capsys.readouterr()
    assert not [line for line in cap.out.splitlines() if "not redrawn" in line], cap.out
    warned = [r.getMessage() for r in caplog.records if f.name in r.getMessage()]
    assert len(warned) == 1 and "differ from the checksum" in warned[0] and "re-simulating" in warned[0], warned
    manifest = copy / "manifest.json"
    m = json.loads(manifest.read_text())
    m["campaign_data"]["duration_s"] = -1.0
    manifest.write_text(json.dumps(m))
    (copy / "manifest.json.sha256").unlink()
    assert main(["plot", str(copy), "--replace"]) == 1  # figures the campaign has were not drawn: a script must see it
    cap = capsys.readouterr()
    out = cap.out.splitlines()
    bad = [line for line in cap.err.splitlines() if "duration_s" in line]
    assert len(bad) == 1 and bad[0].startswith("ur5fault: error: ") and "neither read nor simulated again" in bad[0], \
        cap.err
    assert any(line.startswith("replaced ") and "severity_" in line for line in out), out  # what could be drawn was
    stale = sorted(line for line in out if line.endswith("from an earlier plot, not redrawn now"))
    assert [s.split("/")[-1].split(".png")[0][:4] for s in stale] == ["fig3", "fig4"], out


def test_an_effect_whose_feature_is_nan_in_all_its_runs_gets_a_line_not_a_blank_figure(tmp_path):
    """A sampled diagnostics campaign simulates a healthy twin for backlash runs only (`twins: [backlash]`), so the
    default feature tcp_dev_max_mm is NaN on every other fault's runs: `plot` wrote 12 empty figures (axes 0-1, no
    data) and said "wrote" of each. Now such an effect gets one line saying why, and the others their figures."""
    feats = pd.DataFrame({
        "run_id": ["a", "b", "c", "d", "h"], "status": ["ok"] * 5,
        "fault": ["backlash", "backlash", "torque_constant", "torque_constant", "healthy"],
        "fault_joint": [2, 2, 3, 3, 0], "backlash_deg": [0.1, 0.2, np.nan, np.nan, np.nan],
        "torque_constant_scale": [np.nan, np.nan, 0.8, 0.9, np.nan],
        "tcp_dev_max_mm": [1.0, 2.0, np.nan, np.nan, 0.0], "twin_run_id": ["h", "h", "", "", ""],
    })
    manifest = {"name": "x", "threshold_mm": 0.5, "swept_keys": ["backlash.backlash_deg", "torque_constant.scale"]}
    result = CampaignResult(tmp_path, feats, manifest)
    figs, messages, failures = drawn_and_failed(result, skip=(FIG3_STEM, FIG4_STEM))
    assert failures == []
    assert sorted(figs) == ["heatmap_backlash_tcp_dev_max_mm", "severity_backlash_tcp_dev_max_mm"]
    # torque_constant's figures are not named for plot's check of earlier files either
    assert sorted(figure_stems(result)) == sorted([FIG3_STEM, FIG4_STEM, *figs])
    assert messages == ["no figure for effect 'torque_constant': tcp_dev_max_mm is missing (NaN) in all 2 of its runs "
                        "(the TCP deviation is measured against a healthy twin, which a sampled campaign simulates "
                        "only for the fault kinds of its sample's `twins` key); choose another --feature, e.g. "
                        "current_spike_max_A"]


def test_the_paper_figures_of_a_sampled_campaign_say_what_they_need(tmp_path):
    """In a sampled campaign each backlash run has its own motion, conditions and twin: the paper figures kept the
    largest group of one twin (one run) and said "no backlash run at 0.1 deg (levels: 0.3177)" and "no backlash
    run on joint 2" of a campaign with 11 backlash runs, one on joint 2. Now once: what the figures need."""
    feats = pd.DataFrame({
        "run_id": ["a", "b", "c", "t1", "t2", "t3"], "status": ["ok"] * 6,
        "fault": ["backlash"] * 3 + ["healthy"] * 3, "fault_joint": [1, 2, 3, 0, 0, 0],
        "backlash_deg": [0.05, 0.1, 0.3, np.nan, np.nan, np.nan], "tcp_dev_max_mm": [1.0, 2.0, 3.0, 0, 0, 0],
        "twin_run_id": ["t1", "t2", "t3", "", "", ""],
    })
    manifest = {"name": "x", "threshold_mm": 0.5, "swept_keys": ["backlash.backlash_deg"],
                "campaign_data": {"sample": {"n": 3}}}
    messages = drawn_and_failed(CampaignResult(tmp_path, feats, manifest))[1]
    assert messages == [f"{tmp_path}: no Fig. 3 or Fig. 4: they need backlash runs of several sizes or joints under "
                        "one condition (one healthy twin shared, as `ur5fault campaign run paper` makes); this "
                        "sampled campaign's 3 backlash run(s) each have their own"]
    # a grid whose backlash runs are under several conditions (one twin each) draws the largest group, as before
    from ur5fault.plotting.paper import _backlash_rows

    grid = CampaignResult(tmp_path, feats, {**manifest, "campaign_data": {"sweep": {}}})
    assert len(_backlash_rows(grid)) == 1
    # backlash runs without a twin (the sample's twins key left them out): said, not a time series of run ""
    feats["twin_run_id"] = ""
    with pytest.raises(ParameterError, match=r"no Fig. 3 or Fig. 4: no backlash run has a healthy twin"):
        _backlash_rows(CampaignResult(tmp_path, feats, manifest))


def test_sampled_sizes_are_points_not_a_line_through_other_motions(two):
    """A sampled campaign draws each run's size on its own motion and conditions: a line through them in size order
    zig-zagged between motions. Past MANY_SIZES distinct sizes the points stand alone; a swept grid keeps its line."""
    import dataclasses

    from ur5fault.campaign.summary import MANY_SIZES

    def joint_lines(fig):
        return [ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("J")]

    sweep = effect_sweep(two.features, "backlash", ["backlash_deg"])
    grid = joint_lines(severity_figure(sweep))
    assert grid and all(ln.get_linestyle() == "-" for ln in grid)
    n = MANY_SIZES + 5  # continuous sizes, one run each, spread over the joints: fewer than MANY_SIZES per joint
    sampled = pd.concat([sweep.rows.iloc[[k % len(sweep.rows)]] for k in range(n)], ignore_index=True)
    sampled["size"] = np.linspace(0.01, 0.5, n)
    lines = joint_lines(severity_figure(dataclasses.replace(sweep, rows=sampled)))
    assert len(lines) >= 2 and all(len(ln.get_xdata()) <= MANY_SIZES for ln in lines)
    assert all(ln.get_linestyle() == "None" for ln in lines) and sum(len(ln.get_xdata()) for ln in lines) == n


# ----------------------------------------------------------------------------- bad input, refused by name
@pytest.fixture(scope="module")
def short_pair():
    """Two runs of 20 ms standing still: tables to draw, cheap to make."""
    from ur5fault.sim.trajectories import hold

    return Simulator().run(hold(seconds=0.1), [RunSpec("a", 1), RunSpec("b", 2)], duration_s=0.02)


def test_run_figure_refuses_what_is_not_a_run_table(short_pair):
    df = short_pair.to_pandas(0)
    cases = [
        ({"series": short_pair}, r"^series = <SimResult 2 run\(s\) .* must be a run's time-series table \(a pandas "
                                 r"DataFrame\) \(a SimResult: give res.to_pandas\(run\)\)$"),
        ({"series": "run.parquet"}, r"^series = 'run.parquet' must be a run's time-series table \(a pandas DataFrame\) "
                                    r"\(a file: read it with pandas.read_parquet, or draw it with `ur5fault show "
                                    r"FILE`\)$"),
        ({"series": None}, r"^series = None must be a run's time-series table \(a pandas DataFrame\)$"),
        ({"series": df.iloc[:0]}, r"^series: the time series has no rows: nothing to draw$"),
        ({"series": df, "twin": short_pair}, r"^twin = <SimResult .* \(a SimResult: give res.to_pandas\(run\)\)$"),
        ({"series": df, "twin": df.iloc[:5]}, r"^twin: 5 samples, the run 20: give the twin of the same motion, "
                                              r"duration and log period$"),
        ({"series": df, "twin": df[["t_s"]]}, r"^twin: the healthy twin's table lacks column 'tcp_x_m' \(its TCP is "
                                              r"what the run's deviation is measured from\)$"),
        ({"series": df, "gear_ratio": [101, 101, 101]}, r"^gear_ratio = \[101, 101, 101\] must be one positive number "
                                                        r"or 6, one per joint$"),
        ({"series": df, "gear_ratio": [0] * 6}, r"^gear_ratio = \[0, 0, 0, 0, 0, 0\] must be one positive number"),
        ({"series": df, "gear_ratio": "101"}, r"^gear_ratio = '101' must be one positive number"),
        ({"series": df, "axes": 5}, r"^axes = 5 must be 5 matplotlib Axes \(joint angle, tracking error, encoder "
                                    r"mismatch, motor current, TCP deviation\)$"),
        ({"series": df, "axes": ["a"] * 5}, r"^axes = \['a', 'a', 'a', 'a', 'a'\] must be 5 matplotlib Axes"),
        ({"series": df, "title": 5}, r"^title = 5 must be a string, or None for the run's own$"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ParameterError, match=message):
            run_figure(**kwargs)
    assert isinstance(run_figure(df, twin=short_pair.to_pandas(1), gear_ratio=101), Figure)
    assert isinstance(run_figure(df, gear_ratio=np.full(6, 101.0)), Figure)


def test_campaign_figures_refuse_what_is_not_a_campaign_result():
    from ur5fault.plotting import campaign_figures, fig4_shoulder_current, heatmap

    for draw, name in ((fig3_tcp_deviation, "fig3_tcp_deviation"), (fig4_shoulder_current, "fig4_shoulder_current"),
                       (campaign_figures, "campaign_figures")):
        with pytest.raises(ParameterError, match=rf"^{name}: result = 'results/x' must be a CampaignResult; read the "
                                                 r"folder with CampaignResult.load\('results/x'\)$"):
            draw("results/x")
        with pytest.raises(ParameterError, match=rf"^{name}: result = None must be a CampaignResult$"):
            draw(None)
    for draw, name in ((severity_figure, "severity_figure"), (heatmap, "heatmap")):
        with pytest.raises(ParameterError, match=rf"^{name}: sweep = 'backlash' must be an EffectSweep "
                                                 r"\(effect_sweep\(features, effect\) returns one"):
            draw("backlash")
        with pytest.raises(ParameterError, match=rf"^{name}: sweep = 3 must be an EffectSweep "
                                                 r"\(effect_sweep\(features, effect\)\)$"):
            draw(3)


def test_severity_figures_refuse_an_empty_sweep_and_bad_options():
    from ur5fault.campaign.summary import EffectSweep
    from ur5fault.plotting import heatmap

    empty = EffectSweep("backlash", "backlash_deg", "deg", True, pd.DataFrame(columns=["size", "fault_joint"]), 2)
    for draw, name in ((severity_figure, "severity_figure"), (heatmap, "heatmap")):
        with pytest.raises(ParameterError, match=rf"^{name}: the backlash sweep holds no successful run: nothing to "
                                                 r"draw$"):
            draw(empty)
    one = EffectSweep("backlash", "backlash_deg", "deg", True, pd.DataFrame({"size": [0.1], "fault_joint": [2]}), 0)
    with pytest.raises(ParameterError, match=r"^severity_figure: feature = 5 must be the name of a feature column "
                                             r"\(e.g. 'tcp_dev_max_mm'\)$"):
        severity_figure(one, 5)
    with pytest.raises(ParameterError, match=r"^severity_figure: threshold_mm = '0.5' must be a number, or None$"):
        severity_figure(one, threshold_mm="0.5")
    with pytest.raises(ParameterError, match=r"^severity_figure: healthy = 'x' must be the healthy runs' feature rows"):
        severity_figure(one, healthy="x")
    with pytest.raises(ParameterError, match=r"^severity_figure: ax = 'ax' must be a matplotlib Axes to draw into, or "
                                             r"None for a new figure$"):
        severity_figure(one, ax="ax")


def test_plot_campaign_and_save_refuse_what_is_not_a_path_or_figure(tmp_path):
    from ur5fault.plotting import save

    with pytest.raises(ParameterError, match=r"^plot_campaign: out = 5 must be a folder path$"):
        plot_campaign(5)
    with pytest.raises(ParameterError, match=r"^plot_campaign: feature = None must be the name of a feature column"):
        plot_campaign(tmp_path, feature=None)
    with pytest.raises(ParameterError, match=r"^save: figures = \[1\] must be a mapping of file stem -> matplotlib "
                                             r"Figure$"):
        save([1], tmp_path)
    with pytest.raises(ParameterError, match=r"^save: figures\['a'\] = 1 must be a matplotlib Figure$"):
        save({"a": 1}, tmp_path)
    with pytest.raises(ParameterError, match=r"^save: figure name '../a' must be a plain file stem \(no folder\)$"):
        save({"../a": Figure()}, tmp_path)
    with pytest.raises(ParameterError, match=r"^save: folder = None must be a folder path$"):
        save({"a": Figure()}, None)
    assert list(tmp_path.iterdir()) == []
