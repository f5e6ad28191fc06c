"""Text tables as datasets publish them (msg_adapters/text_files.py, csv_io.py): compressed whole
with the standard library's gzip, bz2 and lzma, other separators, a byte-order mark, comment lines and
numpy.savetxt's header, suffixes in capitals; and files of kinds no reader knows, refused naming the
kinds."""

from __future__ import annotations

import bz2
import gzip
import lzma
from pathlib import Path

import numpy as np
import pytest
from cli_runs import listing, run_cli, the_error
from recorded_bags import columns, joint_states, write_baxter_export, write_rostopic_table

from baxter_dynamics_ros.cli.inputs import expand_inputs
from baxter_dynamics_ros.core.joints import arm_joint_names
from baxter_dynamics_ros.errors import RecordingFileError
from msg_adapters.recording_files import read_recording
from msg_adapters.text_files import kind_suffix, stem

N = 300
COMPRESSORS = {".gz": gzip.compress, ".bz2": bz2.compress, ".xz": lzma.compress}


def assert_left_arm(rec, states: dict) -> None:
    assert rec.side == "left"
    for got, want in zip((rec.q, rec.qd, rec.effort), columns(states, arm_joint_names("left"))):
        np.testing.assert_array_equal(got, want)


def test_kind_and_stem_read_through_a_compression_suffix_only_after_a_text_table() -> None:
    cases = {
        "run.csv": (".csv", "run"), "run.CSV": (".csv", "run"), "run.csv.gz": (".csv", "run"), "a.b.txt.BZ2": (".txt", "a.b"),
        "run.tsv.xz": (".tsv", "run"), "run.mat.gz": (".gz", "run.mat"), "run.parquet.gz": (".gz", "run.parquet"),
        "run.gz": (".gz", "run"), "bag_folder": ("", "bag_folder"), "run.mcap": (".mcap", "run"),
    }  # fmt: skip
    for name, (kind, bare) in cases.items():
        assert (kind_suffix(Path("/data") / name), stem(name)) == (kind, bare), name


@pytest.mark.parametrize("suffix", [".csv.gz", ".txt.bz2", ".tsv.xz", ".CSV.GZ"])
def test_a_compressed_table_reads_as_the_table_itself(tmp_path: Path, suffix: str) -> None:
    states = joint_states(N, rate_hz=50.0)
    plain = write_baxter_export(tmp_path / "plain.csv", states)
    packed = tmp_path / f"run{suffix}"
    packed.write_bytes(COMPRESSORS[Path(suffix.lower()).suffix](plain.read_bytes()))
    rec = read_recording(packed, rate_hz=50.0, note=None)
    assert_left_arm(rec, states)
    np.testing.assert_array_equal(rec.stamps_ns, read_recording(plain, rate_hz=50.0, note=None).stamps_ns)


def test_semicolons_tabs_and_a_byte_order_mark_are_read_as_the_header_separates(tmp_path: Path) -> None:
    states = joint_states(N, rate_hz=50.0)
    text = write_baxter_export(tmp_path / "plain.csv", states).read_text()
    for name, body in {"semi.csv": text.replace(" ", ";"), "tabs.tsv": text.replace(" ", "\t"), "bom.csv": "\ufeff" + text}.items():
        (tmp_path / name).write_text(body, encoding="utf-8")
        assert_left_arm(read_recording(tmp_path / name, rate_hz=50.0, note=None), states)


def test_quoted_fields_and_decimal_commas_as_spreadsheets_export_them(tmp_path: Path) -> None:
    """Python's csv writer quoting every field, and a spreadsheet's export where the comma is the
    decimal mark (fields separated by semicolons, ``-0,5``, text quoted): the same values, exactly."""
    import csv

    states = joint_states(N, rate_hz=50.0)
    q, qd, tau = columns(states, arm_joint_names("left"))
    header = [f"{p}_{j}" for p in ("ang", "vel", "torq") for j in arm_joint_names("left")]
    values = np.hstack([q, qd, tau])
    with open(tmp_path / "quoted.csv", "w", newline="") as f:
        writer = csv.writer(f, quoting=csv.QUOTE_ALL)
        writer.writerows([header, *(map(repr, map(float, row)) for row in values)])
    with open(tmp_path / "comma.csv", "w", newline="") as f:
        writer = csv.writer(f, delimiter=";", quoting=csv.QUOTE_NONNUMERIC)
        writer.writerows([header, *([repr(float(v)).replace(".", ",") for v in row] for row in values)])
    assert (tmp_path / "quoted.csv").read_text().startswith('"ang_left_s0","ang_left_s1"')
    assert (tmp_path / "comma.csv").read_text().splitlines()[1].startswith('"' + repr(float(q[0, 0])).replace(".", ",") + '";')
    for name in ("quoted.csv", "comma.csv"):
        assert_left_arm(read_recording(tmp_path / name, rate_hz=50.0, note=None), states)


def test_columns_of_text_beside_the_joint_columns_are_passed_over(tmp_path: Path) -> None:
    """A date and a label per row (pandas' to_csv of a DataFrame indexed by time, a trial's name):
    not read, the joint columns read exactly; a row whose fields are not the header's as many (a
    date holding a space between whitespace-separated fields) refused, not read shifted; text in a
    joint column refused."""
    states = joint_states(N, rate_hz=50.0)
    text = write_baxter_export(tmp_path / "plain.csv", states).read_text().splitlines()
    dates = [f"2019-05-03T12:00:{k / 50:08.5f}" for k in range(N)]
    for name, sep in (("labelled.csv", ","), ("labelled.txt", " ")):
        rows = [sep.join(["date", "trial", *text[0].split()])] + [sep.join([d, "circle", *row.split()]) for d, row in zip(dates, text[1:])]
        (tmp_path / name).write_text("\n".join(rows) + "\n")
        assert_left_arm(read_recording(tmp_path / name, rate_hz=50.0, note=None), states)
    spaced = [" ".join(["date", "trial", *text[0].split()])] + [" ".join([d.replace("T", " "), "circle", *row.split()]) for d, row in zip(dates, text[1:])]
    (tmp_path / "spaced.txt").write_text("\n".join(spaced) + "\n")
    with pytest.raises(RecordingFileError, match=f"the header names {len(text[0].split()) + 2} columns but data row 1 has {len(text[0].split()) + 3}"):
        read_recording(tmp_path / "spaced.txt", rate_hz=50.0, note=None)
    (tmp_path / "word.txt").write_text("\n".join([text[0], *text[1:5], text[5].replace(text[5].split()[3], "x", 1), *text[6:]]) + "\n")
    with pytest.raises(RecordingFileError, match="not a table of numbers under a header line"):
        read_recording(tmp_path / "word.txt", rate_hz=50.0, note=None)


def test_a_time_column_of_dates_and_times_gives_the_stamps(tmp_path: Path) -> None:
    """Dates and times as exports write them, the texts made by Python's datetime (str(), isoformat()
    with an offset, strftime as the rosbag_to_csv tool and ISO with Z write them, with a decimal
    comma), crossing midnight: each read as the UTC time it is, to the ns; times of day alone, a day
    added past midnight; a Parquet timestamp beside a column of text; a time column that holds
    neither, refused naming it."""
    import datetime as dt

    import pyarrow as pa
    import pyarrow.parquet as pq

    states = joint_states(N, rate_hz=50.0)
    text = write_baxter_export(tmp_path / "plain.csv", states).read_text().splitlines()
    start = dt.datetime(2019, 5, 12, 23, 59, 58, 500_000)  # UTC; N samples at 50 Hz pass midnight
    moments = [start + dt.timedelta(microseconds=int(ns) // 1000) for ns in states["stamps_ns"] - states["stamps_ns"][0]]
    utc_ns = (int((start - dt.datetime(1970, 1, 1)).total_seconds()) * 1_000_000 + start.microsecond) * 1000
    want = utc_ns + states["stamps_ns"] - states["stamps_ns"][0]
    plus2 = dt.timezone(dt.timedelta(hours=2))
    writers = {
        "pandas": str,
        "offset": lambda t: t.replace(tzinfo=dt.timezone.utc).astimezone(plus2).isoformat(),
        "rosbag_to_csv": lambda t: t.strftime("%Y/%m/%d/%H:%M:%S.%f"),
        "zulu": lambda t: t.strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
        "of_day": lambda t: t.strftime("%H:%M:%S.%f"),
        "decimal_comma": str,  # a spreadsheet's export where the comma is the decimal mark
    }
    for name, write in writers.items():
        rows = [",".join(["time", *text[0].split()])] + [",".join([write(t), *row.split()]) for t, row in zip(moments, text[1:])]
        if name == "decimal_comma":
            rows = [row.replace(",", ";").replace(".", ",") for row in rows]
            assert rows[1].startswith("2019-05-12 23:59:58,500000;")
        (tmp_path / f"{name}.csv").write_text("\n".join(rows) + "\n")
        rec = read_recording(tmp_path / f"{name}.csv", note=None)
        assert_left_arm(rec, states)
        np.testing.assert_array_equal(rec.stamps_ns - (rec.stamps_ns[0] - want[0] if name == "of_day" else 0), want, err_msg=name)
    assert str(moments[0]) == "2019-05-12 23:59:58.500000" and str(moments[75]) == "2019-05-13 00:00:00"
    q, qd, tau = columns(states, arm_joint_names("left"))
    table = {"time": pa.array(want, pa.timestamp("ns", tz="UTC")), "trial": ["circle"] * N}
    table |= {f"{p}_{j}": v[:, k] for p, v in (("ang", q), ("vel", qd), ("torq", tau)) for k, j in enumerate(arm_joint_names("left"))}
    pq.write_table(pa.table(table), tmp_path / "stamped.parquet")
    rec = read_recording(tmp_path / "stamped.parquet", note=None)
    assert_left_arm(rec, states)
    np.testing.assert_array_equal(rec.stamps_ns, want)
    rows = (tmp_path / "pandas.csv").read_text().splitlines()
    rows[9] = "yesterday" + rows[9][rows[9].index(",") :]
    (tmp_path / "word.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(RecordingFileError, match="the time column time holds neither numbers nor dates and times \\(row 9: not a date and time: 'yesterday'\\)"):
        read_recording(tmp_path / "word.csv", note=None)


def test_a_row_of_units_under_the_names_is_read_as_their_units(tmp_path: Path) -> None:
    """A row of units under the header, as some exports write (``rad rad/s N·m``, ``[°] [°/s]
    [Nm]``, one left empty): each read as a unit in the column's name, degrees converted; a unit no
    column may have (mrad) leaves the column unknown, and the table is refused naming it."""
    states = joint_states(N, rate_hz=50.0)
    text = write_baxter_export(tmp_path / "plain.csv", states).read_text().splitlines()
    units = ["rad"] * 7 + ["rad/s"] * 7 + ["N·m"] * 6 + [""]
    (tmp_path / "si.csv").write_text("\n".join([text[0].replace(" ", ","), ",".join(units), *(r.replace(" ", ",") for r in text[1:])]) + "\n")
    assert_left_arm(read_recording(tmp_path / "si.csv", rate_hz=50.0, note=None), states)
    q, qd, tau = columns(states, arm_joint_names("left"))
    degrees = np.hstack([np.degrees(q), np.degrees(qd), tau])
    rows = [text[0], " ".join(["[°]"] * 7 + ["[°/s]"] * 7 + ["[Nm]"] * 7), *(" ".join(repr(float(v)) for v in row) for row in degrees)]
    (tmp_path / "deg.txt").write_text("\n".join(rows) + "\n")
    rec = read_recording(tmp_path / "deg.txt", rate_hz=50.0, note=None)
    np.testing.assert_allclose(rec.q, q, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(rec.qd, qd, rtol=1e-14, atol=1e-14)
    np.testing.assert_array_equal(rec.effort, tau)
    ones = [text[0], " ".join(["1"] * 7 + ["2"] * 7 + ["-1"] * 7), *text[2:]]  # a first row of numbers without a digit but 1, 2
    (tmp_path / "ones.txt").write_text("\n".join(ones) + "\n")
    rec = read_recording(tmp_path / "ones.txt", rate_hz=50.0, note=None)
    assert len(rec) == N and rec.q[0].tolist() == [1.0] * 7 and rec.effort[0].tolist() == [-1.0] * 7
    rows[1] = rows[1].replace("[°]", "mrad", 1)
    (tmp_path / "mrad.txt").write_text("\n".join(rows) + "\n")
    with pytest.raises(RecordingFileError, match=r"the left arm needs columns missing here: ang_left_s0"):
        read_recording(tmp_path / "mrad.txt", rate_hz=50.0, arm="left", note=None)


def test_trials_laid_end_to_end_each_timed_from_zero_are_taken_apart(tmp_path: Path) -> None:
    """A time column that starts again from 0 at each trial: each trial read as it is, the next
    moved to begin 10 periods after the one before ends (a gap: the recording cut there), a note
    saying so; a time column that goes back at most rows refused."""
    first, second = joint_states(N, rate_hz=50.0, seed=1), joint_states(N // 2, rate_hz=50.0, seed=2)
    header = ",".join(["time_s", *(f"{p}_{j}" for p in ("ang", "vel", "torq") for j in arm_joint_names("left"))])
    rows = [header]
    for states in (first, second):
        q, qd, tau = columns(states, arm_joint_names("left"))
        t = (states["stamps_ns"] - states["stamps_ns"][0]) * 1e-9
        rows += [",".join(repr(float(v)) for v in (t[k], *q[k], *qd[k], *tau[k])) for k in range(len(t))]
    (tmp_path / "trials.csv").write_text("\n".join(rows) + "\n")
    notes: list[str] = []
    rec = read_recording(tmp_path / "trials.csv", note=notes.append)
    want = np.concatenate([np.arange(N), N - 1 + 10 + np.arange(N // 2)]) * 20_000_000
    np.testing.assert_array_equal(rec.stamps_ns, want)
    for got, a, b in zip((rec.q, rec.qd, rec.effort), columns(first, arm_joint_names("left")), columns(second, arm_joint_names("left"))):
        np.testing.assert_array_equal(got, np.vstack([a, b]))
    assert [(stop - start) for start, stop in rec.segments] == [N, N // 2]
    assert notes == [
        f"{tmp_path / 'trials.csv'}: the time column time_s goes back at 1 row(s) (first after sample {N - 1}): trials laid end to end, "
        "taken apart there (gaps of unknown length, 10 samples in the stamps)"
    ]
    shuffled = [rows[0], *np.random.default_rng(0).permutation(rows[1:])]
    (tmp_path / "shuffled.csv").write_text("\n".join(shuffled) + "\n")
    with pytest.raises(RecordingFileError, match=r"the time column time_s goes back at \d+ of 449 steps: the rows are no time series"):
        read_recording(tmp_path / "shuffled.csv", note=None)


def test_comment_lines_are_passed_over_and_numpy_savetxt_s_header_is_read(tmp_path: Path) -> None:
    states = joint_states(N, rate_hz=50.0)
    q, qd, tau = columns(states, arm_joint_names("left"))
    header = " ".join(f"{p}_{j}" for p in ("ang", "vel", "torq") for j in arm_joint_names("left"))
    np.savetxt(tmp_path / "savetxt.txt", np.hstack([q, qd, tau]), header=f"recorded on a Baxter\n{header}", fmt="%.17g")
    assert (tmp_path / "savetxt.txt").read_text().startswith("# recorded on a Baxter\n# ang_left_s0 ")
    assert_left_arm(read_recording(tmp_path / "savetxt.txt", rate_hz=50.0, note=None), states)
    text = write_baxter_export(tmp_path / "plain.csv", states).read_text()
    (tmp_path / "preamble.csv").write_text("# a note\n#\n" + text)  # comments, then the header as a line of its own
    assert_left_arm(read_recording(tmp_path / "preamble.csv", rate_hz=50.0, note=None), states)
    (tmp_path / "comments.csv").write_text("# a note\n# another\n")
    with pytest.raises(RecordingFileError, match="empty file, expected a header line"):
        read_recording(tmp_path / "comments.csv", rate_hz=50.0, note=None)


def test_a_compressed_rostopic_table_is_recognised(tmp_path: Path) -> None:
    states = joint_states(N)
    plain = write_rostopic_table(tmp_path / "joint_states.csv", states)
    packed = tmp_path / "joint_states.csv.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    rec = read_recording(packed, arm="left", note=None)
    assert_left_arm(rec, states)
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])


def test_broken_compressed_tables_and_unknown_kinds_are_refused_naming_the_file(tmp_path: Path) -> None:
    states = joint_states(N, rate_hz=50.0)
    data = write_baxter_export(tmp_path / "plain.csv", states).read_bytes()
    broken = {
        "cut.csv.gz": (gzip.compress(data)[:2000], "cannot read the file \\(it is cut short"),
        "fake.csv.gz": (data, "cannot read the file \\(Not a gzipped file"),
        "fake.txt.bz2": (data, "cannot read the file \\(Invalid data stream"),
        "fake.tsv.xz": (data, "cannot read the file \\(Input format not supported"),
        "binary.csv.gz": (gzip.compress(bytes(range(256)) * 4), "not a text table"),
        "run.zip": (data, "not a kind of recording this package reads \\(.zip\\); it reads bags .bag"),
        "run.mat.gz": (gzip.compress(data), "not a kind of recording this package reads \\(.gz\\)"),
        "run": (data, "not a kind of recording this package reads \\(no suffix\\)"),
    }
    for name, (content, says) in broken.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(RecordingFileError, match=f"^{tmp_path / name}: {says}"):
            read_recording(tmp_path / name, rate_hz=50.0, note=None)


def test_folders_list_compressed_tables_and_process_names_their_outputs_without_suffixes(tmp_path: Path) -> None:
    folder = tmp_path / "published"
    folder.mkdir()
    states = joint_states(N, rate_hz=50.0)
    data = write_baxter_export(tmp_path / "plain.csv", states).read_bytes()
    (folder / "one.csv.gz").write_bytes(gzip.compress(data))
    (folder / "two.txt.xz").write_bytes(lzma.compress(data))
    (folder / "readme.md").write_text("no recording\n")
    (folder / "all.zip").write_bytes(b"PK\x05\x06" + bytes(18))
    assert expand_inputs([folder]) == [folder / "one.csv.gz", folder / "two.txt.xz"]
    out = tmp_path / "out"
    done = run_cli("process", folder, "--arm", "left", "--rate-hz", "50", "--out", out, "--format", "csv")
    assert done.returncode == 0, done.stderr
    assert listing(out) == ["one.csv", "two.csv"]
    line = the_error(run_cli("process", folder / "all.zip", "--arm", "left", "--out", tmp_path / "zip.csv"))
    assert f"{folder / 'all.zip'}: not a kind of recording this package reads (.zip)" in line
    assert not (tmp_path / "zip.csv").exists()
