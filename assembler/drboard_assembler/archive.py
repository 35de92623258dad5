"""Read a .tar.gz of a run folder without letting it write outside a temporary folder."""

from __future__ import annotations

import gzip
import lzma
import shutil
import tarfile
import zlib
from collections.abc import Iterator
from pathlib import Path, PurePosixPath

from . import limits
from .errors import AssemblyError

ARCHIVE_SUFFIXES = (".tar.gz", ".tgz", ".tar")


def is_archive(path: Path) -> bool:
    return path.is_file() and path.name.lower().endswith(ARCHIVE_SUFFIXES)


def unpack(archive: Path, into: Path) -> Path:
    """Check every member, then extract regular files and folders into ``into``.

    Refuses absolute paths, ``..``, links and devices, more than MAX_ARCHIVE_MEMBERS members and
    more than MAX_ARCHIVE_UNPACKED_BYTES in all. Returns the run folder inside ``into``.
    """
    name = str(archive)
    try:
        with tarfile.open(archive, "r:*") as tar:
            for member in _checked_members(tar, name):
                _write(tar, member, into)
            _check_the_rest(tar, name)
    except tarfile.TarError as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise AssemblyError(name, "", f"not a readable tar archive ({reason})") from None
    except (zlib.error, lzma.LZMAError, EOFError, gzip.BadGzipFile) as error:
        raise AssemblyError(name, "", f"not a readable tar archive ({error or 'truncated'})") from None
    except OSError as error:
        raise AssemblyError(name, "", f"cannot be unpacked ({error})") from None
    return _single_top_folder(into)


def _check_the_rest(tar: tarfile.TarFile, name: str) -> None:
    """What follows the last member must be the archive's end: zero blocks, and for a
    compressed archive a stream that ends as it should (its checksum is read last). A damaged
    member header ends tarfile's reading quietly, and would otherwise lose the files after it."""
    left = 64 * 1024 * 1024
    stream = tar.fileobj
    assert stream is not None
    while left > 0:
        chunk = stream.read(min(left, 1024 * 1024))
        if not chunk:
            return
        if chunk.strip(b"\0"):
            raise AssemblyError(name, "", "not a readable tar archive (damaged after its last "
                                "readable member)")
        left -= len(chunk)


def _write(tar: tarfile.TarFile, member: tarfile.TarInfo, into: Path) -> None:
    """Write one checked member as a plain file or folder: no modes, owners or times taken from
    the archive (tarfile's own extraction filters need Python 3.11.4 or newer)."""
    target = into.joinpath(*PurePosixPath(member.name).parts)
    if member.isdir():
        target.mkdir(parents=True, exist_ok=True)
        return
    source = tar.extractfile(member)
    if source is None:
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    with source, target.open("wb") as out:
        shutil.copyfileobj(source, out)


def _checked_members(tar: tarfile.TarFile, name: str) -> Iterator[tarfile.TarInfo]:
    total = 0
    for count, member in enumerate(tar, start=1):
        if count > limits.MAX_ARCHIVE_MEMBERS:
            raise AssemblyError(name, "", f"holds more than {limits.MAX_ARCHIVE_MEMBERS} members")
        path = PurePosixPath(member.name)
        if path.is_absolute() or member.name.startswith(("/", "\\")):
            raise AssemblyError(name, member.name, "absolute paths are not allowed in an archive")
        if ".." in path.parts:
            raise AssemblyError(name, member.name, "'..' is not allowed in an archive path")
        if member.issym() or member.islnk():
            raise AssemblyError(name, member.name, "links are not allowed in an archive")
        if not (member.isfile() or member.isdir()):
            raise AssemblyError(name, member.name, "only files and folders are allowed")
        total += member.size
        if total > limits.MAX_ARCHIVE_UNPACKED_BYTES:
            raise AssemblyError(name, member.name, "the archive unpacks to more than "
                                f"{limits.MAX_ARCHIVE_UNPACKED_BYTES:,} bytes")
        yield member


def _single_top_folder(into: Path) -> Path:
    entries = [p for p in into.iterdir() if not p.name.startswith(".")]
    if len(entries) == 1 and entries[0].is_dir():
        return entries[0]
    return into
