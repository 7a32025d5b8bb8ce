#!/usr/bin/env python3
"""Any results file as CSV, one row per record: python3 plots/to_csv.py RESULTS --out FILE.

Columns are the union of the records' fields (scalars as they are, lists and objects as JSON), in order of first
appearance, with the file's experiment, date and host in front, for spreadsheets and pandas."""
import argparse
import csv
import io
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from files import is_one_of, written_atomically  # noqa: E402

CONTEXT_COLUMNS = ("experiment", "date", "host_name")


def cell(value):
    if isinstance(value, (dict, list)):
        return json.dumps(value, sort_keys=True)
    if isinstance(value, bool):
        return "true" if value else "false"
    return "" if value is None else value


def rows_of(doc):
    """(columns, rows) of one results document."""
    context = doc.get("context") if isinstance(doc.get("context"), dict) else {}
    records = [r for r in doc.get("benchmarks", []) if isinstance(r, dict)]
    columns = [f"context_{c}" for c in CONTEXT_COLUMNS]
    seen = set(columns)
    for rec in records:
        for key in rec:
            if key not in seen:
                seen.add(key)
                columns.append(key)
    front = {f"context_{c}": context.get(c) for c in CONTEXT_COLUMNS}
    return columns, [{k: cell(v) for k, v in {**front, **rec}.items()} for rec in records]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("results", type=Path)
    parser.add_argument("--out", type=Path, help="CSV file (default: standard output)")
    args = parser.parse_args(argv)
    if args.out and is_one_of(args.out, [args.results]):
        print(f"to_csv: refused: --out {args.out} is the results file it reads", file=sys.stderr)
        return 2
    try:
        doc = json.loads(args.results.read_text())
    except (OSError, ValueError, RecursionError) as err:  # RecursionError: nested deeper than Python reads
        print(f"to_csv: cannot read {args.results}: {err}", file=sys.stderr)
        return 2
    if not isinstance(doc, dict) or not isinstance(doc.get("benchmarks"), list):
        print(f"to_csv: {args.results} is not a results file (no 'benchmarks' list)", file=sys.stderr)
        return 2
    columns, rows = rows_of(doc)
    text = io.StringIO(newline="")
    writer = csv.DictWriter(text, fieldnames=columns, restval="")
    writer.writeheader()
    writer.writerows(rows)
    if not args.out:
        with open(sys.stdout.fileno(), "w", newline="", closefd=False) as stream:
            stream.write(text.getvalue())
        return 0
    try:
        written_atomically(args.out, lambda tmp: Path(tmp).write_bytes(text.getvalue().encode()))
    except OSError as err:
        print(f"to_csv: cannot write {args.out}: {err.strerror}", file=sys.stderr)
        return 2
    print(f"to_csv: {len(rows)} records -> {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
