"""Geolocation as processing chains write it, and everyday files (issue 21)."""

from __future__ import annotations

from geoboresight.batch import read_jobs
from geoboresight.io.tables import read_table


def test_one_table_reader_for_every_delimiter(tmp_path):
    for sep in (",", ";", "\t"):
        p = tmp_path / "t.csv"
        p.write_bytes(f"a{sep}b{sep}c\n1{sep}2{sep}3\n".encode("utf-8-sig"))
        t = read_table(p)
        assert t.header == ["a", "b", "c"] and t.rows == [["1", "2", "3"]] and t.delimiter == sep
    p.write_bytes("a;b\n\xe9;2\n".encode("cp1252"))  # Excel's plain "CSV" on Windows
    assert read_table(p).rows == [["é", "2"]]


def test_jobs_csv_with_a_byte_order_mark(tmp_path):
    comma = tmp_path / "c.csv"
    comma.write_bytes("input,igm,output\nr.tif,i.bil,x.tif\n".encode("utf-8-sig"))
    assert read_jobs(str(comma)) == [{"input": "r.tif", "igm": "i.bil", "output": "x.tif"}]
