"""The authored-asset benchmark counts a damaged case fixed only by the damage's own verdict (issue 27): a repaired
file that reads back valid by the tool's reading but still has faces the damage reversed is not fixed."""
import numpy as np

from neuraluv_paper.bench.authored import _markdown
from neuraluv_paper.damage import damage_left


def _row(case, **kw):
    return {"asset": "a.glb", "case": case, "exit": 0, "time_s": 1.0, "faces": 10, "valid_read_back": True,
            "bit_identical": 1.0, **kw}


def test_a_case_that_reads_valid_with_its_damage_left_in_it_is_not_counted_fixed():
    rows = [_row("as made", problems_before=0, byte_identical=True),
            _row("local fold", damage_left=0, damage_faces=5),
            _row("vertex noise", damage_left=3, damage_faces=5),   # read valid by the tool, the fold still there
            _row("NaN UVs")]                                        # faces that do not line up: not measured
    md = _markdown(rows, [])
    assert "**1/3** fixed" in md and "1 not measured" in md
    assert "| 3 of 5 |" in md and "| 0 of 5 |" in md


def test_damage_left_judges_by_the_layout_as_made_and_leaves_rounding_alone():
    UV = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1], [2, 0]])
    FUV = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3]])
    bad = UV.copy()
    bad[3] = [-0.5, -0.5]                            # faces 1 and 2 turned over
    left, hit = damage_left((UV, FUV), (bad, FUV), (bad, FUV))
    assert hit.tolist() == [False, True, True] and left.tolist() == [False, True, True]
    fixed = UV.copy()
    fixed[3] = [1.01, 0.99]                          # mended, not to the same bits
    assert not damage_left((UV, FUV), (bad, FUV), (fixed, FUV))[0].any()
    lost = UV.copy()
    lost[4] = np.nan                                 # a row without UVs: face 2 hit, left while still without
    left, hit = damage_left((UV, FUV), (lost, FUV), (lost, FUV))
    assert hit.tolist() == [False, False, True] and left.tolist() == [False, False, True]
    left, hit = damage_left((UV, FUV), (bad, FUV), (bad, FUV), judged=np.array([True, True, False]))
    assert hit.tolist() == [False, True, False]      # a face without 3D area is not judged
    thin = np.array([[0.0, 0], [1, 0], [0.5, 1e-9]])  # thinner than float32 rounding: never judged
    assert not damage_left((thin, [[0, 1, 2]]), (thin * [1, -1], [[0, 1, 2]]), (thin * [1, -1], [[0, 1, 2]]))[1].any()
