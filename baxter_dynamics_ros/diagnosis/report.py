"""The diagnosis written out: diagnosis.json, effects.yaml and report.html with its PNG plots.

The report opens offline: plots are PNG files beside it (and embedded as data URIs, so the HTML
alone is enough), no script, no CDN.
"""

from __future__ import annotations

import base64
import html
import json
import os
from pathlib import Path

import numpy as np
import yaml

from ..core.effect_specs import effects_to_dict
from ..core.joints import JOINTS as N
from ..core.output_files import staged_outputs
from .result import STABLE_FRACTION, DiagnosisResult, cutoff_text

__all__ = ["effects_yaml", "write_diagnosis"]

#: Parameters listed per effect in the report's table (all are in diagnosis.json).
MAX_PARAMS_SHOWN = 8
OUTPUT_FILES = ("diagnosis.json", "effects.yaml", "report.html", "residual_over_time.png", "regimes.png", "before_after.png")


def _short(names: tuple[str, ...]) -> list[str]:
    return [n.split("_", 1)[-1] for n in names]


#: Largest magnitude plotted, N·m; beyond it (an absurd sample, an overflow) a value is left out of
#: the plot, where matplotlib's tick placement would overflow (issue 22 item 2).
PLOT_LIMIT = 1e12


def _plottable(values) -> np.ndarray:
    """values as floats, with the non-finite ones and those beyond ±PLOT_LIMIT made NaN (not drawn)."""
    a = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(a) & (np.abs(a) <= PLOT_LIMIT), a, np.nan)


def _plot_residuals(result: DiagnosisResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = result.test_series
    fig, axes = plt.subplots(N, 1, figsize=(11, 13), sharex=True)
    for j, ax in enumerate(axes):
        ax.plot(s["t_s"], _plottable(s["baseline"][:, j]), lw=0.6, color="0.6", label="rigid model, raw q̈")
        ax.plot(s["t_s"], _plottable(s["filtered"][:, j]), lw=0.8, color="tab:blue", label="rigid model, filtered q̈")
        ax.plot(s["t_s"], _plottable(s["final"][:, j]), lw=0.8, color="tab:red", label="with the selected effects")
        ax.set_ylabel(f"{_short(result.joint_names)[j]}\nN·m")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[0].set_title("Residual (measured effort − model) on the held-out test data")
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _plot_regimes(result: DiagnosisResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = result.gap_filtered
    bands = summary.bands
    regimes = list(dict.fromkeys(b.regime for b in bands))
    fig, axes = plt.subplots(len(regimes), 1, figsize=(11, 2.4 * len(regimes)))
    joints = _short(result.joint_names)
    x = np.arange(len(joints))
    for ax, regime in zip(np.atleast_1d(axes), regimes):
        members = [b for b in bands if b.regime == regime]
        width = 0.8 / len(members)
        for k, band in enumerate(members):
            with np.errstate(divide="ignore", invalid="ignore"):
                ax.bar(x + k * width - 0.4 + width / 2, np.nan_to_num(_plottable(band.rms / summary.rms)), width, label=band.label)
        ax.axhline(1.0, color="0.3", lw=0.8)
        ax.set_xticks(x, joints)
        ax.set_ylabel("RMS / joint's RMS")
        ax.set_title(f"Residual RMS by {regime.replace('_', ' ')}, relative to each joint's overall RMS (rigid model, filtered q̈, test data)", fontsize=9)
        ax.legend(fontsize=7, ncol=min(len(members), 5))
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _plot_before_after(result: DiagnosisResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    joints = _short(result.joint_names)
    x = np.arange(len(joints))
    ordered = [e for e in result.selected() if e.name == "acceleration_noise"] + [e for e in result.selected() if e.name != "acceleration_noise"]
    steps = [("rigid model (raw q̈)", result.baseline_test_rms)] + [(f"+ {e.name}", e.test_rms_after) for e in ordered]
    fig, ax = plt.subplots(figsize=(11, 4))
    width = 0.8 / len(steps)
    for k, (label, rms) in enumerate(steps):
        ax.bar(x + k * width - 0.4 + width / 2, _plottable(rms), width, label=label)
    ax.set_yscale("log")
    ax.set_xticks(x, joints)
    ax.set_ylabel("held-out RMS [N·m]")
    ax.set_title("Held-out residual RMS per joint as the selected effects are added")
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _img(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"><figcaption>{html.escape(alt)} ({path.name})</figcaption></figure>'


def _table(head: list[str], rows: list[list[str]]) -> str:
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def _fmt_params(e) -> str:
    fitted = [(k, v) for k, v in e.params.items() if abs(v) > 0] if e.selected else []
    # The inertial change's many parameters: the largest here, all of them in diagnosis.json.
    shown = sorted(fitted, key=lambda kv: -abs(kv[1]))[:MAX_PARAMS_SHOWN] if len(fitted) > MAX_PARAMS_SHOWN else fitted
    def sd(k: str) -> str:
        if k not in e.params_std:
            return ""
        return f" ± {e.params_std[k]:.2g}" if np.isfinite(e.params_std[k]) else " (at its bound)"

    text = ", ".join(f"{k} = {v:.4g}{sd(k)}" for k, v in shown)
    return (text + (", … (all in diagnosis.json)" if len(shown) < len(fitted) else "")) or "—"


def _inertial_section(result: DiagnosisResult) -> str:
    rows = []
    for e in result.selected():
        for link in e.inertial or []:
            before = link.get("before")
            com = ", ".join(f"{v:+.4f}" for v in link["com_m"])
            inertia = ", ".join(f"{v:.2e}" for v in link["inertia_about_com_kgm2"])
            rows.append(
                [
                    e.name,
                    link["link"],
                    (f"{before['mass_kg']:.3f} → " if before else "") + f"{link['mass_kg']:.3f}"
                    + (f" ± {link['std']['mass']:.2g}" if link["std"]["mass"] is not None else " (at its bound)"),
                    (("(" + ", ".join(f"{v:+.4f}" for v in before["com_m"]) + ") → ") if before else "") + f"({com})",
                    (("(" + ", ".join(f"{v:.2e}" for v in before["inertia_about_com_kgm2"]) + ") → ") if before else "") + f"({inertia})",
                    ", ".join([*link["set_by_prior"], *(f"{q} (at its bound)" for q in link["at_bound"])]) or "none",
                ]
            )
    if not rows:
        return ""
    table = _table(["effect", "link", "mass [kg]", "centre of mass [m] (DH frame)", "inertia about the centre of mass [kg·m²] (xx xy xz yy yz zz)", "not decided by the data (set by the prior)"], rows)
    return (
        "<h2>Inertials fitted inside the physical set</h2><p>Each link's pseudo-inertia stays positive definite; masses stay "
        "within 50–150 % and centres of mass within 5 cm of the paper's values (a payload within its box at the flange). "
        "A quantity whose fitted variance is more than half its prior variance was not decided by the data: "
        "it stays near the paper's value (or the payload prior's).</p>" + table
    )


def _drift_section(result: DiagnosisResult, joints: list[str]) -> str:
    offset = next((e for e in result.selected() if e.name == "torque_offset" and e.drift), None)
    if offset is None:
        return ""
    d = offset.drift
    names = [j.split("_", 1)[-1] for j in d["joints"]]
    rows = [["one constant (fitted on all training data)"] + [f"{v:+.3f}" for v in d["constant_nm"]]]
    rows += [[f"training: {name}"] + [f"{v:+.3f}" for v in vals] for name, vals in d["per_recording_nm"].items()]
    rows += [["spread (SD) across training recordings"] + ["—" if v is None else f"{v:.3f}" for v in d["spread_nm"]]]
    rows += [[f"test (held out): {name}"] + [f"{v:+.3f}" for v in vals] for name, vals in d["test_recordings_nm"].items()]
    drifting = ", ".join(j.split("_", 1)[-1] for j in d["drifting"])
    text = (
        f"<p><b>The offset drifts between recordings at {html.escape(drifting)}</b>: each recording has its own; the constant in "
        "effects.yaml is their fit over all training data, not a property of the robot.</p>"
        if d["drifting"]
        else "<p>The offsets agree across the training recordings (within twice their uncertainty and 0.01 N·m).</p>"
    )
    if d["held_common"]:
        held = ", ".join(f"{j.split('_', 1)[-1]} ({v:.3g} N·m)" for j, v in d["held_common"].items())
        text += (
            f"<p><b>Not drift at {html.escape(held)}</b>: there each recording's own offset would depart from their mean by more "
            f"than a torque sensor drifts ({d['max_drift_nm']:g} N·m) — a state-dependent torque the selected effects lack. "
            "One offset is held for all recordings there.</p>"
        )
    return "<h2>Sensor offsets per recording [N·m]</h2>" + (f"<p>{html.escape(d['note'])}</p>" if d["note"] else "") + text + _table(["recording", *names], rows)


def _html(result: DiagnosisResult, plots: dict[str, Path]) -> str:
    joints = _short(result.joint_names)
    base, den, final = result.baseline_test_rms, result.denoised_test_rms, result.final_test_rms
    gap = result.gap
    where = _table(
        ["joint", "RMS [N·m]", "mean [N·m]", "share of gap", "systematic (< 2 Hz) RMS", "high-frequency RMS", "RMS with filtered q̈"],
        [
            [j, f"{gap.rms[k]:.3f}", f"{gap.mean[k]:+.3f}", f"{gap.share[k]:.1%}", f"{gap.systematic_rms[k]:.3f}", f"{gap.noise_rms[k]:.3f}", f"{result.gap_filtered.rms[k]:.3f}"]
            for k, j in enumerate(joints)
        ],
    )
    effect_rows = []
    for e in result.effects:
        stability = f"{e.folds_selected}/{e.folds}" if e.selected else "—"
        effect_rows.append(
            [
                str(e.rank), e.name, ("yes, uncertain" if e.uncertain else "yes") if e.selected else "no", e.variant or "", ", ".join(_short(e.joints)),
                f"{e.share:.4g}" if e.selected else "—", f"{e.cv_gain:.4g}", stability, _fmt_params(e), e.reason,
            ]  # fmt: skip
        )
    effects = _table(
        ["rank", "effect", "selected", "variant", "joints", "share of the gap [N·m² / sample]", "cross-validated gain on the training data [N·m² / sample] (acceleration_noise: no fit)", "folds selecting it", "fitted parameters (± SD)", "why"],
        effect_rows,
    )
    shrink_rows = [["rigid model, raw q̈"] + [f"{v:.3f}" for v in base]]
    steps = [e for e in result.selected() if e.name == "acceleration_noise"] + [e for e in result.selected() if e.name != "acceleration_noise"]
    for e in steps:
        shrink_rows.append([f"+ {e.name}"] + [f"{a:.3f} ({(a - b) / b:+.0%})" for a, b in zip(e.test_rms_after, e.test_rms_before)])
    shrink_rows.append(["final vs rigid model, raw q̈"] + [f"{a:.3f} ({(a - b) / b:+.0%})" for a, b in zip(final, base)])
    shrink_rows.append(["final vs rigid model, denoised q̈"] + [f"{a:.3f} ({(a - b) / b:+.0%})" for a, b in zip(final, den)])
    shrink = _table(["model", *joints], shrink_rows)
    verdict_rows = []
    for e in result.selected():
        cells = []
        for name in result.joint_names:
            v = e.test_verdict.get(name)
            cells.append("" if v is None else f"{v['verdict']} ({v['rms_without']:.3f} → {v['rms_with']:.3f})")
        verdict_rows.append([e.name] + cells)
    verdicts = _table(["effect (held-out RMS without → with it)", *joints], verdict_rows)
    lo, hi = result.training_span_rad
    coverage = _table(
        ["", *joints],
        [
            ["training data [rad]", *(f"{a:+.2f}…{b:+.2f}" for a, b in zip(lo, hi))],
            ["test samples outside it", *(f"{v:.0%}" + (" (no torque depends on it)" if free else "") for v, free in zip(result.test_outside, result.angle_free))],
            *([f"{Path(label).name} (held out in cross-validation) outside the other training data", *(f"{v:.0%}" for v in share)] for label, share in result.folds_outside.items()),
        ],
    )
    style = (
        "body{font-family:sans-serif;max-width:1300px;margin:2em auto;}table{border-collapse:collapse;margin:1em 0;font-size:90%}"
        "td,th{border:1px solid #bbb;padding:3px 6px;text-align:right}td:nth-child(2),th{text-align:left}img{max-width:100%}"
        ".warn{border:2px solid #c00;background:#fee;padding:0.5em 1em}.ok{border:1px solid #393;background:#efe;padding:0.5em 1em}"
    )
    warnings = result.warnings()
    top = (
        '<div class="warn">' + "".join(f"<p>{html.escape(w)}</p>" for w in warnings) + "</div>"
        if warnings
        else '<div class="ok"><p>On the held-out data no joint is worse with the selected effects than with the denoised rigid-body model, '
        f"and every selected effect was chosen in at least {STABLE_FRACTION:.0%} of the cross-validation folds.</p></div>"
    )
    files = lambda xs: ", ".join(html.escape(x) for x in xs)  # noqa: E731
    search = "".join(f"<li>{html.escape(m)}</li>" for m in result.search) or "<li>no move lowered the score</li>"
    passed = "".join(f"<br>\nPassed over, too short: {html.escape(label)} ({html.escape(why)})." for label, why in result.passed_over.items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Baxter gap diagnosis</title><style>{style}</style></head><body>
<h1>Sim-to-real gap diagnosis — {html.escape(result.arm_side)} arm</h1>
{top}
<p>Fitted on: {files(result.train_files)} (cross-validation: {html.escape(result.holdout)}, {result.folds} folds).<br>
Measured on held-out data: {files(result.test_files)}. No parameter and no selection below used it.{passed}</p>
<h2>Where the gap lies</h2>
<p>Residual = measured effort − rigid-body model with the paper's q̈ (first difference of q̇), on the test data.
The systematic part is what a zero-phase 2 Hz low-pass keeps; the rest is noise, mostly of the
differentiated q̈ (last column: the RMS once q̇ is low-passed at {cutoff_text(result.joint_names, result.cutoff_hz)} before differentiating).</p>
{where}
{_img(plots["regimes.png"], "Residual RMS per joint by motion regime and configuration")}
<h2>Which effects cause it</h2>
<p>Noise first: physical effects are fitted with the filtered q̈ only. Stepwise selection with removals and swaps
between alternatives after every addition, per-joint effects at the joints where they pay, scored by
cross-validation on the training data. Ranked by the share of the gap each explains (for
acceleration_noise: what filtering q̇ removes; for the others: their Shapley share of the rest).
"Folds selecting it": the selection run again on each cross-validation fold's training part;
fewer than {STABLE_FRACTION:.0%} is <i>uncertain</i>.</p>
{effects}
{_inertial_section(result)}
{_drift_section(result, joints)}
<h2>How far it shrinks (held-out test data)</h2>
{shrink}
<h3>The range of each joint the fit's data cover</h3>
<p>Where held-out samples lie outside the angles of the data fitted on, their figures measure how the effects extrapolate.</p>
{coverage}
<h3>Did each effect help on the test data?</h3>
<p>Per joint it acts on: the held-out RMS of the selected set without that effect and with it (both fitted on the training data only).</p>
{verdicts}
{_img(plots["before_after.png"], "Held-out RMS per joint, before and after each selected effect")}
{_img(plots["residual_over_time.png"], "Residual over time on the test data")}
<h2>The search</h2><ol>{search}</ol>
</body></html>
"""


def _json_ready(value):
    """The value with every non-finite float as None (JSON has no NaN: a band without samples, an
    uncertainty a bound decided, is null)."""
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def effects_yaml(result: DiagnosisResult) -> str:
    """effects.yaml: the selected effects (zero at the joints they do not act on), and beside them
    the joints each acts on, the uncertain ones, the q̇ filter they were fitted with (q̈'s, and
    friction's argument) and drifting offsets."""
    selected = [e for e in result.selected() if e.effect is not None]
    drift = next((e.drift for e in selected if e.drift), None)
    doc = {
        "arm": result.arm_side,
        "source": "baxter-dynamics diagnose",
        "q_ddot": {
            "estimator": "zero-phase low-pass of q̇, then central differences; friction fitted on the low-passed q̇",
            "cutoff_hz": dict(zip(result.joint_names, result.cutoff_hz)),
        },
        "joints": {e.name: list(e.joints) for e in selected},
        "uncertain": [e.name for e in selected if e.uncertain],
        **({"offset_drift": {"joints": drift["drifting"], "per_recording_nm": drift["per_recording_nm"]}} if drift and drift["drifting"] else {}),
        "effects": effects_to_dict(tuple(e.effect for e in selected)),
    }
    return "# Effects identified by `baxter-dynamics diagnose`; load into the node with -p effects_file:=<this file>.\n" + yaml.safe_dump(
        doc, sort_keys=False, allow_unicode=True
    )


def write_diagnosis(result: DiagnosisResult, out_dir: str | os.PathLike[str], *, replace: bool = True) -> dict[str, Path]:
    """Write every output file into out_dir (created if needed, with its parents), all or none of
    them (:mod:`~baxter_dynamics_ros.core.output_files`); returns them by name. replace: False
    refuses an earlier diagnosis' files, also one that another run wrote while this one worked."""
    out = Path(out_dir)
    targets = {name: out / name for name in OUTPUT_FILES}
    with staged_outputs(list(targets.values()), replace=replace) as staged:
        _write_all(result, dict(zip(targets, staged)))
    return targets


def _write_all(result: DiagnosisResult, paths: dict[str, Path]) -> None:
    paths["diagnosis.json"].write_text(json.dumps(_json_ready(result.to_dict()), indent=2, allow_nan=False), encoding="utf-8")
    paths["effects.yaml"].write_text(effects_yaml(result), encoding="utf-8")
    _plot_residuals(result, paths["residual_over_time.png"])
    _plot_regimes(result, paths["regimes.png"])
    _plot_before_after(result, paths["before_after.png"])
    paths["report.html"].write_text(_html(result, paths), encoding="utf-8")
