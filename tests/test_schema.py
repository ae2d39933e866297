"""Table helpers of hexatissue.schema."""
import numpy as np
import pandas as pd
import pytest

from hexatissue.errors import InputError
from hexatissue.schema import empty_table, interior_mask, require_columns, rows_by_frame, string_column, track_ids


def test_rows_by_frame_equals_one_scan_per_frame():
    times = np.random.default_rng(3).integers(0, 7, 200)
    times[times == 4] = 9  # a gap in the frames
    rows = rows_by_frame(times)
    assert sorted(rows) == sorted(np.unique(times).tolist())
    for t, at in rows.items():
        np.testing.assert_array_equal(at, np.flatnonzero(times == t))  # in row order


def test_rows_by_frame_of_no_rows_is_empty():
    assert rows_by_frame(np.zeros(0, np.int64)) == {}


def test_track_ids_prefers_track_and_interior_mask_reads_is_border():
    cells = pd.DataFrame({"cell": [4, 5], "track": [10, 11], "is_border": [True, False]})
    np.testing.assert_array_equal(track_ids(cells), [10, 11])
    np.testing.assert_array_equal(track_ids(cells.drop(columns="track")), [4, 5])
    np.testing.assert_array_equal(interior_mask(cells), [False, True])
    np.testing.assert_array_equal(interior_mask(cells.drop(columns="is_border")), [True, True])
    with pytest.raises(InputError, match="'track' or 'cell'"):
        track_ids(pd.DataFrame({"x": [1.0]}))


def test_require_columns_names_what_is_missing():
    with pytest.raises(InputError, match=r"events is missing column\(s\) \['y'\]"):
        require_columns(pd.DataFrame({"x": [1.0]}), ("x", "y"), "events")
    with pytest.raises(InputError, match="must be a pandas DataFrame"):
        require_columns({"x": [1.0]}, ("x",), "events")


def test_empty_table_has_the_schema_columns_per_order():
    cells = empty_table("cells", orders=(2, 6))
    assert len(cells) == 0
    assert {"gamma2_re", "gamma2_im", "gamma6_re", "gamma6_im"} <= set(cells.columns)
    with pytest.raises(InputError, match="table must be one of"):
        empty_table("nope")


@pytest.mark.parametrize("n", [0, 1, 2, 37, 5000])
def test_string_column_equals_pandas_strings_of_the_names(n, tmp_path):
    names = ("cycle", "intercalation", "unresolved", "", "é-ü")  # an empty name and multi-byte characters too
    codes = np.random.default_rng(n).integers(0, len(names), n)
    got = string_column(codes, names)
    want = pd.array(np.asarray(names, dtype=object)[codes], dtype="string")
    pd.testing.assert_extension_array_equal(got, want)
    # and as a table column, through Parquet
    table = pd.DataFrame({"kind": got, "code": codes})
    table.to_parquet(tmp_path / "t.parquet", index=False)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "t.parquet"), pd.DataFrame({"kind": want, "code": codes}),
                                  check_exact=True)


def test_string_column_refuses_codes_outside_the_names():
    with pytest.raises(InputError, match="codes must index the 2 names"):
        string_column([0, 2], ("a", "b"))
    with pytest.raises(InputError, match="codes must index"):
        string_column([-1], ("a", "b"))


def test_rows_by_frame_equals_the_stable_argsort_split_for_sorted_unsorted_and_empty_columns():
    """FrameRows (slices on sorted columns) behind rows_by_frame gives the arrays of one stable argsort."""
    from hexatissue.schema import rows_by_frame

    rng = np.random.default_rng(0)
    for times in (rng.integers(0, 20, 1000), np.sort(rng.integers(0, 20, 1000)), np.zeros(0, int), np.array([3])):
        order = np.argsort(times, kind="stable")
        present, first = np.unique(times[order], return_index=True)
        expected = dict(zip(present.tolist(), np.split(order, first[1:]))) if len(order) else {}
        got = rows_by_frame(times)
        assert list(got) == list(expected)
        for frame, rows in expected.items():
            np.testing.assert_array_equal(got[frame], rows)


def test_the_column_lists_of_0_1_are_read_from_the_schema_with_a_deprecation_warning():
    from hexatissue import events, track
    from hexatissue.schema import TABLES

    with pytest.warns(DeprecationWarning, match="LINEAGE_COLUMNS is deprecated"):
        assert track.LINEAGE_COLUMNS == {c: meaning for c, (_, _, meaning) in TABLES["lineage"].items()}
    with pytest.warns(DeprecationWarning, match="EVENT_EXTRA_COLUMNS is deprecated"):
        assert list(events.EVENT_EXTRA_COLUMNS) == ["frame_gain", "frame_undo", "is_border"]
    with pytest.raises(AttributeError, match="has no attribute 'NO_SUCH_COLUMNS'"):
        events.NO_SUCH_COLUMNS
