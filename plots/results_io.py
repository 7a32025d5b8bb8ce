"""Reads results files (Google Benchmark JSON schema) into plain records for the figures and findings.

Tolerant by design: unknown fields are ignored, missing ones are reported on stderr, nothing is invented.
"""
import json
import math
import sys
from collections import Counter, namedtuple
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
SHAPES = ("hollow_cube", "filled_cube", "hollow_sphere", "filled_sphere")
UNIT_SECONDS = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}

# seconds is None for a skipped cell; max_dist_m is None for k-NN (it does not depend on the distance);
# n_points / n_queries: model and query sizes (record fields, else context.datasets; None when unknown); threads:
# what the timed calls ran on (wall time).
SweepCell = namedtuple("SweepCell", "model query adapter search strategy max_dist_m k seconds skipped found agrees "
                                    "n_points n_queries threads", defaults=(None, None, 1))
# file: index into Results.files, so that figures can take each build from one run rather than mix runs.
Build = namedtuple("Build", "model adapter build_seconds index_bytes n_points file threads", defaults=(None, 1))
# Google Benchmark micro-benchmarks (bench/micro_nns): the fastest repetition's CPU time of one call.
MicroCell = namedtuple("MicroCell", "pair adapter variant max_dist_m cpu_seconds n_queries")
# micro_nns's single-threaded builds (Build/<model>/<adapter>): one record a repetition.
MicroBuild = namedtuple("MicroBuild", "model adapter variant cpu_seconds")
# micro_nns's whole ICP runs (Icp/<pair>/<adapter>, construction excluded): one record a repetition.
MicroIcp = namedtuple("MicroIcp", "pair adapter variant cpu_seconds")
# Ranged 1-NN's wall time on 1 thread (Ranged1NN/<pair>/<adapter>/<m>) and on n (.../threads:<n>/real_time), one
# record a repetition: what the threads figure draws.
MicroWall = namedtuple("MicroWall", "pair adapter variant max_dist_m threads wall_seconds n_queries")
# ref_*: the final pose's error against the pair's reference (None without one); settings: ICP_SETTINGS and
# initial_pose as the record gives them; bucket_source: "best" (from run_icp --buckets-from's file), "default"
# (the adapter is not in that file) or None (no file named); threads: what the searches ran on.
IcpRun = namedtuple("IcpRun", "experiment pair adapter bucket_size icp_seconds build_seconds nns_seconds "
                              "iterations converged ref_translation_error_m ref_rotation_error_deg settings "
                              "bucket_source threads", defaults=(None, None, None, None, 1))
ICP_SETTINGS = ("max_dist_start_m", "max_dist_factor", "max_dist_floor_m", "max_iterations", "query_stride",
                "initial_pose")


_WARNED = set()


def warn(message):
    """One line on stderr, once per distinct message."""
    if message in _WARNED:
        return
    _WARNED.add(message)
    print(f"{Path(sys.argv[0]).name}: {message}", file=sys.stderr)


def _number(value):
    """The value as a finite float, or None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def record_seconds(rec, fields=("median_seconds", "median_s")):
    """The record's time in seconds: the first of `fields` present, else real_time converted by time_unit."""
    for field in (fields,) if isinstance(fields, str) else fields:
        value = _number(rec.get(field))
        if value is not None:
            return value
    real_time, unit = _number(rec.get("real_time")), rec.get("time_unit")
    if real_time is None or unit not in UNIT_SECONDS:
        return None
    return real_time * UNIT_SECONDS[unit]


# A cell's time: the median of its calls (what the figures and claims take by default), or the fastest of them,
# which a slow spell of the machine lasting through some of a cell's calls does not move.
STATISTICS = ("median", "fastest")


def cell_seconds(rec, statistic="median", median_fields=("median_seconds", "median_s")):
    """The record's time by statistic; 'fastest' is its min_s (None when the record keeps no fastest call)."""
    if statistic == "fastest":
        return next((v for v in (_number(rec.get(f)) for f in ("min_seconds", "min_s")) if v is not None), None)
    return record_seconds(rec, median_fields)


def _skip_reason(rec):
    if rec.get("skipped"):
        return str(rec["skipped"])
    if rec.get("error_occurred"):
        return str(rec.get("error_message", "error"))
    return None


class Results:
    """Everything read from a set of results files."""

    def __init__(self):
        self.files = []      # (path, context)
        self.sweep = []      # SweepCell
        self.builds = []     # Build
        self.icp = []        # IcpRun
        self.micro = []      # MicroCell
        self.micro_builds = []  # MicroBuild
        self.micro_icp = []  # MicroIcp
        self.micro_walls = []  # MicroWall
        self.sweep_threads = []  # SweepCell at every thread count run (results.sweep: the fewest a cell ran on)
        self.sweep_every_size = []  # SweepCell at every set size swept (results.sweep: one size a combination)
        self.build_skips = {}  # (model, adapter) -> reason the build did not run
        self.adapters = {}   # name -> {library, version, structure, knn, radius, ranged, exact, params}
        self.duplicates = {}  # record name -> [paths of every file holding it], when more than one
        self.datasets = {}   # (spec, role) -> a context.datasets entry: the last file's (newest with prefer), see merged_dataset
        self.statistic = "median"  # of a cell's calls: its time (see cell_seconds)

    def adapter_info(self, name):
        return self.adapters.get(name, {})

    def _note_adapter(self, rec):
        name = rec.get("adapter")
        if not name:
            return
        info = self.adapters.setdefault(name, {})
        for key in ("library", "version", "structure"):
            if rec.get(key) and not info.get(key):
                info[key] = str(rec[key])
        if rec.get("search") in ("knn", "radius", "ranged") and rec.get("strategy"):
            info.setdefault(rec["search"], rec["strategy"])
        if isinstance(rec.get("exact"), bool):
            info.setdefault("exact", rec["exact"])


def _read_sweep(results, rec, sizes=None, statistic="median"):
    model, query, adapter, search = (rec.get(field) for field in ("model", "query", "adapter", "search"))
    if not (model and query and adapter and search):
        warn(f"sweep record {rec.get('name')!r} lacks model/query/adapter/search: ignored")
        return
    skipped = _skip_reason(rec)
    seconds = None if skipped else cell_seconds(rec, statistic)
    if seconds is None and not skipped:
        wanted = "min_s" if statistic == "fastest" else "median_seconds or real_time+time_unit"
        warn(f"{rec.get('name')}: no time ({wanted}): ignored")
        return
    max_dist = _number(rec.get("max_dist"))
    if max_dist is None and search != "knn":
        warn(f"{rec.get('name')}: {search} cell without max_dist: ignored")
        return
    k = _number(rec.get("k"))
    sizes = sizes or {}
    n_points = _number(rec.get("n_points")) or sizes.get((model, "model"))
    n_queries = _number(rec.get("n_queries")) or sizes.get((query, "query"))
    results.sweep.append(SweepCell(model, query, adapter, search, rec.get("strategy") or "?",
                                   max_dist, k, seconds, skipped, _number(rec.get("found")),
                                   rec.get("agrees") if isinstance(rec.get("agrees"), bool) else None,
                                   n_points, n_queries, record_threads(rec)))
    results._note_adapter(rec)


def _read_build(results, rec, statistic="median"):
    model, adapter = rec.get("model"), rec.get("adapter")
    if model and adapter and _skip_reason(rec):
        results.build_skips[(model, adapter)] = _skip_reason(rec)
        return
    if not (model and adapter):
        warn(f"build record {rec.get('name')!r} incomplete: ignored")
        return
    seconds = cell_seconds(rec, statistic, "build_seconds")
    if seconds is None:
        warn(f"{rec.get('name')}: no {'min_s' if statistic == 'fastest' else 'build_seconds'}: ignored")
        return
    results.builds.append(Build(model, adapter, seconds, _number(rec.get("index_bytes")),
                                _number(rec.get("n_points")), len(results.files) - 1, record_threads(rec)))
    results._note_adapter(rec)


def bucket_source(context, adapter):
    """Whether run_icp ran the adapter at its best bucket from the file its config names, or at its default."""
    config = context.get("config") if isinstance(context.get("config"), dict) else {}
    if not config.get("buckets_from"):
        return None
    return "best" if adapter in (config.get("best_buckets") or {}) else "default"


def _read_icp(results, rec, experiment, context):
    pair, adapter = rec.get("pair"), rec.get("adapter")
    icp_seconds = _number(rec.get("icp_seconds"))
    if not (pair and adapter) or icp_seconds is None or _skip_reason(rec):
        warn(f"icp record {rec.get('name')!r} lacks pair/adapter/icp_seconds or was skipped: ignored")
        return
    converged = rec.get("converged")
    results.icp.append(IcpRun(rec.get("experiment") or experiment, pair, adapter,
                              _number(rec.get("bucket_size")), icp_seconds, _number(rec.get("build_seconds")),
                              _number(rec.get("nns_seconds")), _number(rec.get("iterations")),
                              converged if isinstance(converged, bool) else None,
                              _number(rec.get("ref_translation_error_m")), _number(rec.get("ref_rotation_error_deg")),
                              {k: rec[k] for k in ICP_SETTINGS if k in rec}, bucket_source(context, adapter),
                              record_threads(rec)))
    results._note_adapter(rec)


def _name_parts(rec):
    """micro_nns's records are Google Benchmark's own: their name is all they say (Ranged1NN/pair/adapter/m)."""
    return str(rec.get("name", "")).split("/")


def _micro_record(rec, n_parts):
    """(name parts, adapter, variant or None, CPU seconds) of a micro_nns record of n_parts, else None."""
    parts = _name_parts(rec)
    cpu_time, unit = _number(rec.get("cpu_time")), rec.get("time_unit")
    if len(parts) != n_parts or cpu_time is None or unit not in UNIT_SECONDS:
        return None
    adapter, _, variant = parts[2].partition("[")
    return parts, adapter, variant.rstrip("]") or None, cpu_time * UNIT_SECONDS[unit]


def _read_micro(results, rec):
    """Ranged1NN/<pair>/<adapter[variant]>/<max dist>: keeps each repetition; micro_cells() takes the fastest."""
    got = _micro_record(rec, 4)
    if got is None:
        return
    parts, adapter, variant, seconds = got
    try:
        max_dist = float(parts[3])
    except ValueError:
        return
    n_queries = _number(rec.get("items_per_call"))
    results.micro.append(MicroCell(parts[1], adapter, variant, max_dist, seconds, n_queries))


def _read_micro_wall(results, rec):
    """Ranged1NN/<pair>/<adapter[variant]>/<m>, and the same with /threads:<n>/real_time: wall time a call."""
    parts = _name_parts(rec)
    seconds = record_seconds(rec, ())
    threads = 1
    if len(parts) == 6 and parts[4].startswith("threads:") and parts[5] == "real_time":
        count = parts[4][len("threads:"):]
        threads = int(count) if count.isdigit() else None
    elif len(parts) != 4:
        return
    try:
        max_dist = float(parts[3])
    except ValueError:
        return
    if seconds is None or not threads:
        return
    adapter, _, variant = parts[2].partition("[")
    results.micro_walls.append(MicroWall(parts[1], adapter, variant.rstrip("]") or None, max_dist, threads, seconds,
                                         _number(rec.get("items_per_call"))))


def _read_micro_per_model(into, make, rec):
    """Build/<model>/<adapter[variant]> or Icp/<pair>/<adapter[variant]> as make(...) onto into (a threaded
    build's name has more parts and is not read)."""
    got = _micro_record(rec, 3)
    if got is not None:
        parts, adapter, variant, seconds = got
        into.append(make(parts[1], adapter, variant, seconds))


def _fastest_per_model(records):
    best = {}
    for r in records:
        if r.variant is None:
            best[(r[0], r.adapter)] = min(best.get((r[0], r.adapter), math.inf), r.cpu_seconds)
    return best


def micro_build_cells(results):
    """{(model, adapter): fastest CPU seconds of a single-threaded build}, default variants only."""
    return _fastest_per_model(results.micro_builds)


def micro_icp_cells(results):
    """{(pair, adapter): fastest CPU seconds of a whole ICP run}, default variants only."""
    return _fastest_per_model(results.micro_icp)


def micro_cells(results, variants=False):
    """{(pair, adapter, max_dist): fastest CPU seconds}, default variants only unless asked."""
    best = {}
    for c in results.micro:
        if c.variant is None or variants:
            key = (c.pair, c.adapter if c.variant is None else f"{c.adapter}[{c.variant}]", c.max_dist_m)
            best[key] = min(best.get(key, math.inf), c.cpu_seconds)
    return best


def micro_queries(results):
    """{pair: queries a call answers}, where micro_nns recorded it (items_per_call)."""
    return {c.pair: c.n_queries for c in results.micro if c.n_queries}


def file_ranks(results):
    """Each file's place in time, by its index in results.files: (context date, reading order); larger is newer."""
    return [(file_date(ctx), i) for i, (_, ctx) in enumerate(results.files)]


def build_rank(results, build, ranks=None):
    """The rank (file_ranks) of the file a build came from."""
    return (ranks or file_ranks(results))[build.file] if build.file is not None else ("", 0)


def latest_builds(results):
    """{(model, adapter): Build} at the largest set size any file built it at (the grid's beside quick's), on the
    fewest threads, from the newest file among those (by context date, then reading order)."""
    ranks = file_ranks(results)
    out = {}
    for b in results.builds:
        key = (b.model, b.adapter)
        order = (size_order(b.n_points), -b.threads, build_rank(results, b, ranks))
        if key not in out or order >= out[key][0]:
            out[key] = (order, b)
    return {k: b for k, (_, b) in out.items()}


# Google Benchmark's records from micro_nns, read by name rather than as sweep, build or ICP records.
MICRO_KINDS = ("micro", "micro_build", "micro_icp")


def _kind(rec):
    name = str(rec.get("name", ""))
    if name.startswith("Ranged1NN/"):
        return "micro"
    if name.startswith("Build/"):
        return "micro_build"
    if name.startswith("Icp/"):
        return "micro_icp"
    for prefix in ("sweep", "build", "icp"):
        if name.startswith(prefix + "/"):
            return prefix
    if "icp_seconds" in rec:
        return "icp"
    if "search" in rec and "adapter" in rec:
        return "sweep"
    if "build_seconds" in rec:
        return "build"
    return None


def run_name(rec):
    """The cell a record belongs to: Google Benchmark's run_name (shared by repetitions and aggregates)."""
    return str(rec.get("run_name") or rec.get("name", ""))


def record_threads(rec):
    """The threads a record's timed calls ran on (1 when it does not say)."""
    threads = _number(rec.get("threads"))
    return int(threads) if threads and threads >= 1 else 1


def run_threads(context):
    """The threads a run was given (its config's `threads`; 1 when it does not say)."""
    config = context.get("config") if isinstance(context.get("config"), dict) else {}
    return record_threads(config)


def icp_run_threads(context, pair):
    """The threads run_icp was given on a pair (its config's settings for the pair; 1 when it does not say)."""
    config = context.get("config") if isinstance(context.get("config"), dict) else {}
    for entry in config.get("pairs") or []:
        if isinstance(entry, dict) and entry.get("pair") == pair and isinstance(entry.get("icp"), dict):
            return record_threads(entry["icp"])
    return run_threads(context)


def threads_text(threads):
    return f"run on {threads} threads"


def sized_run_name(rec, sizes, threads=1):
    """The cell with the set sizes and the threads its run was given: the same name at other sizes (quick's 15,000
    points beside the grid's 60,000) or in a run on other threads is another measurement, not a duplicate;
    _one_set_size keeps one size per combination."""
    n_points = _number(rec.get("n_points")) or sizes.get((rec.get("model"), "model"))
    n_queries = _number(rec.get("n_queries")) or sizes.get((rec.get("query"), "query"))
    parts = [f"{n:g} {what}" for n, what in ((n_points, "points"), (n_queries, "queries")) if n]
    parts += [threads_text(threads)] if threads > 1 else []
    return run_name(rec) + (f" ({', '.join(parts)})" if parts else "")


def _median(values):
    values = sorted(values)
    mid = len(values) // 2
    return values[mid] if len(values) % 2 else (values[mid - 1] + values[mid]) / 2


def one_record_per_cell(records):
    """One record per run_name: the median aggregate when there is one, else the only record, else the
    repetitions' median (their real_time) on a copy of the first. Fields missing from an aggregate are taken
    from the cell's first repetition, which carries them."""
    by_cell = {}
    for rec in records:
        if isinstance(rec, dict):
            by_cell.setdefault(run_name(rec), []).append(rec)
    out = []
    for recs in by_cell.values():
        aggregates = [r for r in recs if r.get("run_type") == "aggregate"]
        runs = [r for r in recs if r.get("run_type") != "aggregate"]
        median = next((r for r in aggregates if r.get("aggregate_name") == "median"), None)
        if median is not None:
            out.append({**(runs[0] if runs else {}), **median, "name": run_name(median)})
        elif len(runs) == 1:
            out.append(runs[0])
        elif runs:
            out.append(_median_of_repetitions(runs))
    return out


def _median_of_repetitions(runs):
    timed = [r for r in runs if not _skip_reason(r) and _number(r.get("real_time")) is not None]
    first = dict(runs[0])
    if not timed:
        return first
    for field in ("median_seconds", "median_s", "mean_s", "min_s", "stddev_s"):
        first.pop(field, None)
    first["real_time"] = _median([_number(r["real_time"]) for r in timed])
    first.pop("skipped", None), first.pop("error_occurred", None)
    return first


def experiment_of(context):
    """The experiment's name (`experiment`; ICP files made before it was written so say `nnb_experiment`)."""
    return context.get("experiment") or context.get("nnb_experiment")


def merged_dataset(older, newer):
    """A later file's entry for a scan wins; the fields it does not record are kept from an earlier file's
    entry for the same data (equal sha256), so that a file recording less does not erase what another said."""
    if older and older.get("sha256") == newer.get("sha256"):
        return {**older, **newer}
    return newer


def file_date(context):
    return str(context.get("date") or "")


def load(paths, prefer=None, statistic="median"):
    """Reads every results file; a file that cannot be read is reported and left out. statistic: each sweep
    cell's and build's time is the median of its calls, or the fastest (see cell_seconds).

    A record (name and set sizes) found in several files is noted in Results.duplicates; the copy used is the
    newest file's (context date, then reading order) when prefer == "newest", else the last one read. Callers that
    must not guess refuse duplicates unless asked to prefer the newest (see provenance.py)."""
    results = Results()
    results.statistic = statistic
    docs = []
    for path in paths:
        try:
            doc = json.loads(Path(path).read_text())
        except (OSError, ValueError, RecursionError) as err:  # RecursionError: nested deeper than Python reads
            warn(f"{path}: cannot read results ({err}): ignored")
            continue
        if not isinstance(doc, dict) or not isinstance(doc.get("benchmarks"), list):
            warn(f"{path}: not a results file (no 'benchmarks' list): ignored")
            continue
        context = doc.get("context") if isinstance(doc.get("context"), dict) else {}
        docs.append((str(path), context, doc["benchmarks"]))
    if prefer == "newest":
        docs.sort(key=lambda d: file_date(d[1]))  # stable: reading order among equal dates
    seen = {}
    sweep_files = []  # the file of each cell of results.sweep
    for path, context, benchmarks in docs:
        results.files.append((path, context))
        for name, info in (context.get("adapters") or {}).items():
            if isinstance(info, dict):
                results.adapters.setdefault(name, {}).update({k: v for k, v in info.items() if v is not None})
        datasets = {(d.get("spec"), d.get("role")): d for d in (context.get("datasets") or []) if isinstance(d, dict)}
        for key, entry in datasets.items():
            results.datasets[key] = merged_dataset(results.datasets.get(key), entry)
        sizes = {key: _number(d.get("points")) for key, d in datasets.items()}
        micro = [r for r in benchmarks if isinstance(r, dict) and _kind(r) in MICRO_KINDS]
        for rec in micro:
            if rec.get("run_type") == "aggregate":
                continue
            kind = _kind(rec)
            if kind == "micro":
                _read_micro(results, rec)
                _read_micro_wall(results, rec)
            elif kind == "micro_build":
                _read_micro_per_model(results.micro_builds, MicroBuild, rec)
            else:
                _read_micro_per_model(results.micro_icp, MicroIcp, rec)
        for rec in one_record_per_cell(r for r in benchmarks if isinstance(r, dict)
                                       and _kind(r) not in MICRO_KINDS):
            kind = _kind(rec)
            if kind in ("sweep", "build"):
                seen.setdefault(sized_run_name(rec, sizes, run_threads(context)), []).append(path)
            elif kind == "icp":  # each ICP experiment is drawn on its own: the same cell in two is no conflict
                threads = icp_run_threads(context, rec.get("pair"))
                on_threads = f" ({threads_text(threads)})" if threads > 1 else ""
                seen.setdefault(f"{experiment_of(context)}: {run_name(rec)}{on_threads}", []).append(path)
            if kind == "sweep":
                _read_sweep(results, rec, sizes, statistic)
                sweep_files.append(path)
            elif kind == "build":
                _read_build(results, rec, statistic)
            elif kind == "icp":
                _read_icp(results, rec, experiment_of(context), context)
    results.duplicates = {name: files for name, files in seen.items() if len(set(files)) > 1}
    rank = {path: r for (path, _), r in zip(results.files, file_ranks(results))}
    every_size = _one_k(_last_wins(results.sweep, lambda c: (*_sweep_key(c), c.n_points, c.n_queries, c.threads)))
    results.sweep_every_size = _fewest_threads(every_size, lambda c: (*_sweep_key(c), c.n_points, c.n_queries), None)
    results.sweep = _one_set_size(results.sweep, sweep_files, rank)
    results.sweep_threads = _one_k(_last_wins(results.sweep, lambda c: (*_sweep_key(c), c.threads)))
    results.sweep = _fewest_threads(results.sweep_threads)
    results.icp = _fewest_threads(_last_wins(results.icp, lambda r: (*_icp_key(r), r.threads)), _icp_key, "ICP runs")
    return results


def _one_set_size(cells, files, rank):
    """A combination swept at other set sizes in another file (quick's 15,000 points beside the grid's 60,000) is
    not the same series: per (model, query), cells at other sizes than the largest any file swept it at (the
    grid's, whichever ran last; among files at those sizes the newest by context date, then reading order: rank)
    are left out, and said so."""
    chosen = {}
    for cell, path in zip(cells, files):
        key = (cell.model, cell.query)
        order = (size_order(cell.n_points, cell.n_queries), rank[path])
        if key not in chosen or order >= chosen[key][0]:
            chosen[key] = (order, path, (cell.n_points, cell.n_queries))
    kept, dropped = [], Counter()
    for cell, path in zip(cells, files):
        _, last_path, sizes = chosen[(cell.model, cell.query)]
        known = None not in sizes and None not in (cell.n_points, cell.n_queries)
        if path != last_path and known and (cell.n_points, cell.n_queries) != sizes:
            dropped[(path, cell.model, cell.query, last_path)] += 1
        else:
            kept.append(cell)
    for (path, model, query, last_path), n in dropped.items():
        warn(f"{path}: {n} cells of {model} -> {query} left out: other set sizes than {last_path}'s")
    return kept


def size_order(*sizes):
    """Orders set sizes, unknown (None) below any known one."""
    return tuple(-1 if n is None else n for n in sizes)


def _last_wins(items, key):
    by_key = {}
    for item in items:
        by_key[key(item)] = item
    return list(by_key.values())


def _sweep_key(cell):
    return cell.model, cell.query, cell.adapter, cell.search, cell.strategy, cell.max_dist_m, cell.k


def _icp_key(run):
    return run.experiment, run.pair, run.adapter, run.bucket_size


def _fewest_threads(cells, key=_sweep_key, what="sweep cells"):
    """Each cell (key) at the fewest threads it ran on (the paper's comparison is single-threaded); says so, naming
    what the cells are, when one drawn ran on more (what=None: silently)."""
    fewest = {}
    for cell in cells:
        if key(cell) not in fewest or cell.threads < fewest[key(cell)].threads:
            fewest[key(cell)] = cell
    threaded = Counter(c.threads for c in fewest.values() if c.threads > 1) if what else {}
    for threads, n in sorted(threaded.items()):
        warn(f"{n} {what} ran on {threads} threads only: their wall times are drawn as they are")
    return list(fewest.values())


def _one_k(cells):
    """Figures and claims concern 1-NN (the ICP case); with several k, keep the smallest."""
    ks = sorted({c.k for c in cells if c.k is not None})
    if len(ks) <= 1:
        return cells
    warn(f"sweep has k = {ks}: only k = {ks[0]:g} is used")
    return [c for c in cells if c.k is None or c.k == ks[0]]


def default_inputs():
    """Reference results (with the micro-benchmarks) if there are any, else every results/*.json."""
    for pattern in ("results/reference/*.json", "results/*.json"):
        found = sorted(REPO_ROOT.glob(pattern))
        micro = REPO_ROOT / Path(pattern).parent / "micro_nns" / "micro_nns.json"
        if found and micro.is_file():
            found.append(micro)
        if found:
            return found
    return []


def display_path(path):
    """A results file's path relative to the repository when it lies inside, so outputs do not name the clone."""
    try:
        return str(Path(path).resolve().relative_to(REPO_ROOT))
    except ValueError:
        return str(path)


def is_default_strategy(results, cell):
    """Whether the cell ran its adapter's default strategy for its search (the one the figures compare)."""
    return cell.strategy == results.adapter_info(cell.adapter).get(cell.search, cell.strategy)


def sweep_series(results, model, query, every_strategy=False, cells=None):
    """{(adapter, search): sorted cells} for one model/query combination, each adapter's default strategy;
    with every_strategy, {(adapter, search, strategy): sorted cells} over every strategy run. From cells when
    given, else from results.sweep."""
    series = {}
    for cell in results.sweep if cells is None else cells:
        if cell.model == model and cell.query == query:
            if every_strategy:
                series.setdefault((cell.adapter, cell.search, cell.strategy), []).append(cell)
            elif is_default_strategy(results, cell):
                series.setdefault((cell.adapter, cell.search), []).append(cell)
    for cells in series.values():
        cells.sort(key=lambda c: -1.0 if c.max_dist_m is None else c.max_dist_m)
    return series
