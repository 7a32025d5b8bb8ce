"""Output files written whole or not at all: a temporary beside the target, fsync, then a rename, so that an
interrupted script leaves the last whole file (a README, a figure, the findings), never half of one."""
import os
import tempfile
from pathlib import Path


def written_atomically(path, write):
    """Calls write(temporary) for a temporary beside path with path's suffix (writers that go by the suffix,
    as matplotlib's savefig does, still can), then moves it over path; on any failure the temporary goes."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.tmp.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # as a plain open would make it, not mkstemp's 0600
        write(tmp)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def is_one_of(path, others):
    """Whether path names the same file as one of others (existing or not, links followed)."""
    target = Path(path).resolve()
    return any(Path(other).resolve() == target for other in others)


def write_atomically(path, text):
    written_atomically(path, lambda tmp: Path(tmp).write_text(text))
