"""tests/tf/reference.json is what tests/ros/tf_reference.py computes with numpy (no ROS needed):
the Rust buffer's lookups are held to these numbers by `tf::tests::lookups_match_the_numpy_reference`.
"""

import json

import numpy as np

import tf_reference


def test_the_reference_file_is_numpys():
    saved = json.loads(tf_reference.OUT.read_text())
    fresh = json.loads(tf_reference.encoded())
    assert saved["transforms"] == fresh["transforms"]
    assert len(saved["lookups"]) == len(fresh["lookups"])
    for s, f in zip(saved["lookups"], fresh["lookups"]):
        assert [s[k] for k in ("target", "source", "time_ns", "latest")] == \
            [f[k] for k in ("target", "source", "time_ns", "latest")]
        assert s.get("error") == f.get("error")
        if "error" not in f:
            assert np.allclose(s["translation"], f["translation"], rtol=0, atol=1e-12)
            assert np.allclose(s["rotation"], f["rotation"], rtol=0, atol=1e-12)


def test_the_reference_covers_every_case():
    lookups = json.loads(tf_reference.OUT.read_text())["lookups"]
    errors = {lk.get("error") for lk in lookups}
    assert {"not_connected", "future", None} <= errors, errors
    # Lookups between samples (not at a stamp) exercise the interpolation.
    assert sum(1 for lk in lookups if "error" not in lk and lk["time_ns"] % 1000 != 0) >= 5


def test_slerp_and_matrices_agree_with_rotation_about_z():
    # 0 and 90 degrees about z, halfway: 45 degrees.
    a = np.array([0, 0, 0, 1.0])
    b = np.array([0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)])
    m = tf_reference.matrix(tf_reference.slerp(a, b, 0.5))
    c = np.cos(np.pi / 4)
    assert np.allclose(m, [[c, -c, 0], [c, c, 0], [0, 0, 1]])
