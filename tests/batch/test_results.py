"""Result sets on disk: Parquet and JSON lines, round trips, resuming, cut-short and stale files,
one writer at a time."""

import json
import os
import time

import pytest

from graphpose import InputError
from graphpose.batch.results import (
    SCHEMA,
    arrow_schema,
    flat_row,
    nested_record,
    open_results,
    parameters,
    read_results,
    results_format,
)
from graphpose.batch.work import estimate_images
from tests.batch.helpers import make_image_set
from tests.conftest import REPO

pytest.importorskip("pyarrow")


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Real rows: two with a pose, a corrupt file and a missing one."""
    images = make_image_set(tmp_path_factory.mktemp("results-images"), n_files=2, n_paths=2)
    items = [(p, images.bounds.get(p)) for p in images.all_paths]
    rows = estimate_images(items, images.K, images.board)
    assert [r["status"] for r in rows] == ["ok", "ok", "unreadable", "missing"]
    return rows


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("name", ["r.parquet", "r.jsonl", "r.ndjson"])
def test_rows_read_back_as_written(records, tmp_path, name):
    with open_results(tmp_path / name) as results:
        assert results.done == set()
        for r in records:
            results.write(r)
        assert results.done == {r["image"] for r in records}
    assert read_results(tmp_path / name) == records


def test_parquet_columns_hold_every_key_of_a_record(records):
    for r in records:
        assert set(r) - {"cross_check"} <= set(SCHEMA)  # a new record key needs a column
        assert set(flat_row(r)) == set(SCHEMA) == set(arrow_schema().names)
        assert nested_record(flat_row(r)) == r


def test_docs_describe_every_column():
    text = (REPO / "docs" / "batch.md").read_text()
    assert [name for name in SCHEMA if f"`{name}`" not in text] == []


def test_parquet_parts_of_failed_rows_only_and_of_poses_read_as_one(records, tmp_path):
    out = tmp_path / "r.parquet"
    with open_results(out) as results:
        for r in records[2:]:  # a first part without a pose: its pose columns all null
            results.write(r)
        results.flush()
        for r in records[:2]:
            results.write(r)
    assert len(list(out.glob("part-*.parquet"))) == 2
    import pyarrow.parquet as pq

    table = pq.read_table(out)  # the folder as one data set, as pandas would read it
    assert table.num_rows == len(records) and table.schema.names == list(SCHEMA)
    assert sorted(read_results(out), key=lambda r: r["image"]) == sorted(records, key=lambda r: r["image"])


@pytest.mark.parametrize("name", ["r.parquet", "r.jsonl"])
def test_reopening_knows_the_images_done_and_adds_to_them(records, tmp_path, name):
    with open_results(tmp_path / name) as results:
        results.write(records[0])
    with open_results(tmp_path / name) as results:
        assert results.done == {records[0]["image"]}
        results.write(records[1])
    assert read_results(tmp_path / name) == records[:2]


def test_a_jsonl_line_cut_short_is_dropped_and_done_again(records, tmp_path):
    out = tmp_path / "r.jsonl"
    with open_results(out) as results:
        results.write(records[0])
    whole = out.read_bytes()
    out.write_bytes(whole + json.dumps(records[1]).encode()[:40])  # a writer killed mid-line
    assert read_results(out) == records[:1]
    with open_results(out) as results:
        assert results.done == {records[0]["image"]}
        results.write(records[1])
    assert read_results(out) == records[:2]
    assert out.read_bytes().count(b"\n") == 2


def test_a_bad_jsonl_line_before_the_last_is_an_error(records, tmp_path):
    out = tmp_path / "r.jsonl"
    out.write_text(json.dumps(records[0]) + "\nnot json\n" + json.dumps(records[1]) + "\n")
    with pytest.raises(InputError, match="line 2"):
        open_results(out)
    with pytest.raises(InputError, match="line 2"):
        read_results(out)


def test_a_part_left_half_written_is_removed_and_never_read(records, tmp_path):
    out = tmp_path / "r.parquet"
    with open_results(out) as results:
        results.write(records[0])
    stale = out / ".part-killed-000000.parquet.tmp"
    stale.write_bytes(b"PAR1 half")
    assert read_results(out) == records[:1]
    with open_results(out) as results:
        assert results.done == {records[0]["image"]}
    assert not stale.exists()


@pytest.mark.parametrize("name", ["r.parquet", "r.jsonl"])
def test_one_writer_at_a_time(records, tmp_path, name):
    with open_results(tmp_path / name), pytest.raises(InputError, match="another run"):
        open_results(tmp_path / name)
    with open_results(tmp_path / name) as results:  # free again
        results.write(records[0])


def test_bad_names_and_places(tmp_path):
    with pytest.raises(InputError, match=r"\.parquet .* or \.jsonl"):
        results_format(tmp_path / "r.csv")
    with pytest.raises(InputError, match="does not exist"):
        open_results(tmp_path / "nowhere" / "r.jsonl")
    with pytest.raises(InputError, match="does not exist"):
        open_results(tmp_path / "nowhere" / "r.parquet")
    (tmp_path / "file.parquet").write_text("")
    with pytest.raises(InputError, match="folder"):
        open_results(tmp_path / "file.parquet")
    (tmp_path / "dir.jsonl").mkdir()
    with pytest.raises(InputError, match="folder"):
        open_results(tmp_path / "dir.jsonl")
    with pytest.raises(InputError, match="flush_seconds"):
        open_results(tmp_path / "r.jsonl", flush_seconds=0)
    with pytest.raises(InputError, match="not found"):
        read_results(tmp_path / "absent.jsonl")


def test_parquet_rows_reach_the_disk_while_results_arrive(records, tmp_path):
    out = tmp_path / "r.parquet"
    with open_results(out, flush_seconds=0.05) as results:
        results.write(records[0])
        assert not list(out.glob("part-*.parquet"))  # waiting in memory
        time.sleep(0.06)
        results.write(records[1])  # older than flush_seconds now: both written
        assert read_results(out) == records[:2]


def test_reopening_knows_what_each_row_was_made_with(records, tmp_path):
    # The resume key: the camera's model and values (not its file), the board, the polygon, robust.
    out = tmp_path / "r.parquet"
    with open_results(out) as results:
        for r in records:
            results.write(r)
    with open_results(out) as results:
        assert results.made == {r["image"]: (parameters(r), r["status"]) for r in records}
    first = records[0]
    renamed = {**first, "camera": {**first["camera"], "file": "elsewhere/cam.yml", "name": "cam0"}}
    assert parameters(renamed) == parameters(first)
    for key, value in (("board", {"cols": 9, "rows": 6, "square_m": 0.03}), ("robust", True), ("bounds", None)):
        assert parameters({**first, key: value}) != parameters(first), key
    assert parameters({k: v for k, v in first.items() if k != "camera"}) is None


def test_an_interrupt_just_after_a_part_is_renamed_does_not_write_its_rows_twice(records, tmp_path, monkeypatch):
    import graphpose.batch.results as module

    out = tmp_path / "r.parquet"
    results = open_results(out)
    replace = os.replace

    def replace_then_interrupt(src, dst):
        replace(src, dst)
        raise KeyboardInterrupt  # Ctrl-C or SIGTERM between the rename and the next line

    for r in records[:2]:
        results.write(r)
    monkeypatch.setattr(module.os, "replace", replace_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        results.flush()
    monkeypatch.undo()
    results.close()  # what graphpose batch does on the way out
    assert sorted(r["image"] for r in read_results(out)) == sorted(r["image"] for r in records[:2])
