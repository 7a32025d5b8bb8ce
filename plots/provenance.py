"""Where each results file came from, and whether the plots may trust it.

Every output that reads results files prints, per file, its git commit (dirty or not), command line, load
average before and after, date and wall time. Inputs from a dirty tree (or with no commit recorded: a clean
tree cannot be shown), runs that overlapped in time on the same host, and records found in more than one file
are refused unless the caller allows them; an allowed problem is kept in `marks` so the output can say so."""
import datetime
import re
import shlex
import sys
from pathlib import Path

import results_io

REFUSED = 2


def add_arguments(parser):
    parser.add_argument("--allow-dirty", action="store_true",
                        help="use inputs from a modified source tree (or with no commit recorded); the output says so")
    parser.add_argument("--allow-overlap", action="store_true",
                        help="use inputs whose runs overlapped in time; the output says so")
    parser.add_argument("--prefer", choices=["newest"],
                        help="records found in several files: take each from the newest file (by context date)")


def is_dirty(context):
    commit = context.get("git_commit")
    return context.get("git_dirty") is True or not commit or str(commit).endswith("+dirty")


def _load_text(load):
    if not isinstance(load, list) or not load:
        return "?"
    return "/".join(f"{x:.2f}" for x in load if isinstance(x, (int, float)))


def start_time(context):
    """The run's start as an aware datetime (naive dates read as UTC), or None."""
    return _when(context.get("date"))


def wall_seconds(context):
    value = context.get("wall_seconds")
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0 else None


def _when(text):
    """An ISO time as an aware datetime (naive ones read as UTC), or None."""
    try:
        when = datetime.datetime.fromisoformat(str(text))
    except ValueError:
        return None
    return when if when.tzinfo else when.replace(tzinfo=datetime.timezone.utc)


def resumed_starts(context):
    """The start of each sitting after the first of a resumed run (context `resumed`), oldest first."""
    resumed = context.get("resumed")
    return sorted(w for w in map(_when, resumed if isinstance(resumed, list) else []) if w is not None)


def interval(context):
    """(start, end) of the run's last sitting when its start and wall time are recorded, else None. The wall
    time is the last sitting's: a resumed run's earlier sittings have no recorded end (see run_log_sittings)."""
    starts = [start_time(context)] + resumed_starts(context)
    start, wall = starts[-1], wall_seconds(context)
    return None if start is None or wall is None else (start, start + datetime.timedelta(seconds=wall))


RUN_LOG = "reference_run_log.txt"
_OUTPUT_FLAGS = ("--out", "--benchmark_out", "--describe-real-pairs")
_LOG_LINE = re.compile(r"^(\S+) (start|end|killed) (\S+?):?(?: (.*?))?(?: \| load.*)?$")


def output_path(command):
    """The file a program's command line writes (--out, --benchmark_out, --describe-real-pairs), or None. A
    command line is split as the shell would (the programs and the reference run quote each word, so that a
    path may hold spaces); a list is taken as its words."""
    words = [str(w) for w in command] if isinstance(command, list) else _shell_words(str(command or ""))
    for i, word in enumerate(words):
        flag, equals, value = word.partition("=")
        if flag in _OUTPUT_FLAGS:
            value = value if equals else (words[i + 1] if i + 1 < len(words) else "")
            return value if value not in ("", "-") else None
    return None


def _shell_words(line):
    try:
        return shlex.split(line)
    except ValueError:  # an unbalanced quote: words as spaces part them
        return line.split()


def run_log_sittings(log_text):
    """{output path: [(start, end)]} from a reference run's log (scripts/reference_run.sh): every sitting of
    every step, each start paired with its step's next end (or the line saying it was killed)."""
    out, open_steps = {}, {}
    for line in log_text.splitlines():
        match = _LOG_LINE.match(line)
        when = _when(match.group(1)) if match else None
        if when is None:
            continue
        kind, step, rest = match.group(2), match.group(3), match.group(4) or ""
        if kind == "start" and output_path(rest):
            open_steps[step] = (output_path(rest), when)
        elif kind in ("end", "killed") and step in open_steps:
            path, start = open_steps.pop(step)
            out.setdefault(path, []).append((start, when))
    return out


def find_run_log(path):
    """The reference run's log beside a results file or one folder up (micro_nns/, hints/), or None."""
    for folder in (Path(path).parent, Path(path).parent.parent):
        if (folder / RUN_LOG).is_file():
            return folder / RUN_LOG
    return None


def sittings(path, context):
    """Every sitting of the run that wrote this file, from the run's log when the log knows them all (as many
    sittings as the file records, the last starting within a minute of the file's), else None."""
    log = find_run_log(path)
    out = output_path(context.get("command_line"))
    found = run_log_sittings(log.read_text(errors="replace")).get(out) if log and out else None
    starts = [start_time(context)] + resumed_starts(context)
    if not found or starts[-1] is None or len(found) != len(starts) \
            or abs((found[-1][0] - starts[-1]).total_seconds()) > 60:
        return None
    return found


def intervals(path, context):
    """The run's time intervals: every sitting from the run's log, else the last sitting (interval)."""
    return sittings(path, context) or [i for i in [interval(context)] if i is not None]


def _sittings_text(path, context):
    logged, resumed = sittings(path, context), resumed_starts(context)
    if logged and len(logged) > 1:
        return f" ({len(logged)} sittings, each checked for overlap from the run's log)"
    if resumed:
        return (f" (its last of {len(resumed) + 1} sittings; the earlier ones' ends are not recorded, so only the last "
                "is checked for overlap)")
    return ""


def describe(path, context):
    """One line of provenance for a results file."""
    commit = context.get("git_commit") or "unknown"
    dirty = " (DIRTY TREE)" if is_dirty(context) and context.get("git_commit") else ("" if context.get("git_commit") else " (NOT RECORDED)")
    command = context.get("command_line") or context.get("executable") or "?"
    if isinstance(command, list):
        command = " ".join(map(str, command))
    wall = wall_seconds(context)
    after = _load_text(context.get("load_avg_after")) if context.get("load_avg_after") else "not recorded"
    return (f"`{results_io.display_path(path)}`: experiment {results_io.experiment_of(context) or '?'}; "
            f"commit {commit}{dirty}; command `{command}`; load {_load_text(context.get('load_avg'))} before, "
            f"{after} after; started {context.get('date', '?')}, "
            f"wall time {'not recorded' if wall is None else f'{wall:.0f} s'}" + _sittings_text(path, context))


LOG_RESOLUTION = datetime.timedelta(seconds=2)  # the log's whole seconds against a file's fractional wall time


def overlaps(files):
    """[(path a, path b)] of runs on the same host (or an unknown one) any of whose time intervals intersect by
    more than the log's resolution."""
    runs = [(path, ctx, intervals(path, ctx)) for path, ctx in files]
    out = []
    for i, (pa, ca, ia) in enumerate(runs):
        for pb, cb, ib in runs[i + 1:]:
            same_host = not ca.get("host_name") or not cb.get("host_name") or ca["host_name"] == cb["host_name"]
            if pa != pb and same_host and any(sa + LOG_RESOLUTION < eb and sb + LOG_RESOLUTION < ea
                                                      for sa, ea in ia for sb, eb in ib):
                out.append((pa, pb))
    return out


class Check:
    """The provenance verdict on a set of results: refusal (one line) or the marks the output must carry."""

    def __init__(self, results, allow_dirty=False, allow_overlap=False, prefer=None):
        self.lines = [describe(path, ctx) for path, ctx in results.files]
        dirty = [results_io.display_path(p) for p, ctx in results.files if is_dirty(ctx)]
        overlapping = overlaps(results.files)
        duplicates = results.duplicates
        problems, self.marks = [], []
        if dirty:
            text = f"{len(dirty)} input(s) from a dirty tree or with no commit recorded ({', '.join(dirty)})"
            (self.marks if allow_dirty else problems).append(text + ("" if allow_dirty else "; --allow-dirty to use them"))
        if overlapping:
            pairs = ", ".join(f"{results_io.display_path(a)} and {results_io.display_path(b)}" for a, b in overlapping)
            text = f"runs overlapped in time: {pairs}"
            (self.marks if allow_overlap else problems).append(text + ("" if allow_overlap else "; --allow-overlap to use them"))
        if duplicates:
            name, paths = next(iter(sorted(duplicates.items())))
            text = (f"{len(duplicates)} record(s) in more than one file (e.g. {name} in "
                    f"{' and '.join(results_io.display_path(p) for p in sorted(set(paths)))})")
            if prefer == "newest":
                self.marks.append(text + ": each taken from the newest file")
            else:
                problems.append(text + "; --prefer newest to take each from the newest file")
        self.refusal = "; ".join(problems) or None

    def banner(self):
        """The loud mark for outputs made from inputs that would otherwise be refused ('' when clean)."""
        return "" if not self.marks else "NOT A CLEAN RUN: " + "; ".join(self.marks)


def check_or_exit(results, args, prog):
    """The Check for the parsed --allow-*/--prefer options; prints provenance; exits 2 (one line) on refusal."""
    check = Check(results, args.allow_dirty, args.allow_overlap, args.prefer)
    if check.refusal:
        print(f"{prog}: refused: {check.refusal}", file=sys.stderr)
        sys.exit(REFUSED)
    for line in check.lines:
        print(f"{prog}: input {line}")
    if check.marks:
        print(f"{prog}: WARNING: {check.banner()}", file=sys.stderr)
    return check
