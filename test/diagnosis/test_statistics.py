"""The statistics pass (diagnosis/statistics.py): each block's sufficient statistics against sums
written out with numpy over the block's samples (sample ranges by integer arithmetic), on residuals
computed without the package's dynamics (Pinocchio's RNEA, scipy's zero-phase filter), and on
regressor columns built here (1 for an offset, q̇ for viscous friction)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_recordings import block_edges, recording, reference_residuals

from baxter_dynamics_ros.diagnosis.statistics import CHUNK, Pool, active_columns, column_layout, prepare, recording_blocks
from baxter_dynamics_ros.diagnosis.validation import validation_arm

N = 7
CUTOFF_HZ = 4.0


@pytest.mark.parametrize(("seconds", "parts"), [(12.03, 4), (12.0, 7), (90.0, 1)], ids=["1203-in-4", "1200-in-7", "longer-than-a-chunk"])
def test_block_statistics_are_sums_over_contiguous_blocks(seconds: float, parts: int) -> None:
    """Blocks cover the recording exactly, in order (block k: samples ⌊kn/parts⌋ to ⌊(k+1)n/parts⌋);
    each one's samples, span, r·r (denoised and raw) and the offset's and viscous friction's entries of
    H and b equal numpy's sums over those samples. The 90 s case is one block of 9000 samples, longer
    than the pass's chunk of 8192 rows, so its last partial chunk must count too."""
    arm = validation_arm()
    rec = recording(arm, 61, seconds, viscous=1.0)
    n = len(rec)
    assert parts > 1 or n > CHUNK
    layout = column_layout()
    blocks = recording_blocks(arm, layout, active_columns(arm, layout), "r", prepare(arm, rec, CUTOFF_HZ), parts)
    raw, den = reference_residuals(arm, rec, CUTOFF_HZ)
    offset = next(c for c in layout.candidates if c.name == "torque_offset")
    viscous = next(c for c in layout.candidates if c.name == "viscous_friction")
    assert [b.index for b in blocks] == list(range(parts))
    for block, (lo, hi) in zip(blocks, block_edges(n, parts)):
        assert block.samples == hi - lo
        assert block.duration_s == pytest.approx(float(rec.stamps_s[hi - 1] - rec.stamps_s[lo]), abs=1e-9)
        np.testing.assert_allclose(block.rr, np.sum(den[lo:hi] ** 2, axis=0), rtol=1e-6)
        np.testing.assert_allclose(block.rr_raw, np.sum(raw[lo:hi] ** 2, axis=0), rtol=1e-6)
        for j in range(N):
            o, v = offset.columns[j], viscous.columns[j]
            qd = rec.qd[lo:hi, j]
            assert block.H[j, o, o] == pytest.approx(hi - lo)
            assert block.H[j, v, v] == pytest.approx(float(qd @ qd), rel=1e-9)
            assert block.H[j, o, v] == pytest.approx(float(qd.sum()), rel=1e-9, abs=1e-9)
            assert block.b[j, o] == pytest.approx(float(den[lo:hi, j].sum()), rel=1e-6, abs=1e-6)
            assert block.b[j, v] == pytest.approx(float(qd @ den[lo:hi, j]), rel=1e-6, abs=1e-6)
    pool = Pool.of(blocks)
    assert pool.samples == n


def test_pool_sums_and_folds() -> None:
    """A pool of two recordings: its sums are the blocks' sums, one group per recording, and each
    fold's training blocks (``fold_blocks``) hold exactly the other recording's samples and r·r."""
    arm = validation_arm()
    layout = column_layout()
    active = active_columns(arm, layout)
    recs = {"a": recording(arm, 62, 6.0), "b": recording(arm, 63, 7.0)}
    blocks = [b for label, rec in recs.items() for b in recording_blocks(arm, layout, active, label, prepare(arm, rec, CUTOFF_HZ), 4)]
    pool = Pool.of(blocks)
    assert pool.groups == (tuple(range(4)), tuple(range(4, 8)))
    den = {k: reference_residuals(arm, r, CUTOFF_HZ)[1] for k, r in recs.items()}
    np.testing.assert_allclose(pool.rr, sum(np.sum(d**2, axis=0) for d in den.values()), rtol=1e-6)
    for g, (held, kept) in enumerate((("a", "b"), ("b", "a"))):
        fold = Pool.of(pool.fold_blocks()[g])
        assert fold.samples == len(recs[kept])
        assert fold.recordings == (kept,)
        np.testing.assert_allclose(fold.rr, np.sum(den[kept] ** 2, axis=0), rtol=1e-6)
        H, b, samples = pool.without_group(g)
        assert samples == len(recs[kept])
        np.testing.assert_allclose(H, fold.H, rtol=1e-9, atol=1e-9)
