"""Read a .tar.gz of a run folder without letting it write outside a temporary folder."""

from __future__ import annotations

import tarfile
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
    name = archive.name
    try:
        with tarfile.open(archive, "r:*") as tar:
            members = _checked_members(tar, name)
            tar.extractall(into, members=members, filter="data")
    except tarfile.TarError as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise AssemblyError(name, "", f"not a readable tar archive ({reason})") from None
    except (OSError, EOFError) as error:
        raise AssemblyError(name, "", f"cannot be unpacked ({error})") from None
    return _single_top_folder(into)


def _checked_members(tar: tarfile.TarFile, name: str) -> list[tarfile.TarInfo]:
    members: list[tarfile.TarInfo] = []
    total = 0
    for member in tar:
        if len(members) >= limits.MAX_ARCHIVE_MEMBERS:
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
        members.append(member)
    return members


def _single_top_folder(into: Path) -> Path:
    entries = [p for p in into.iterdir() if not p.name.startswith(".")]
    if len(entries) == 1 and entries[0].is_dir():
        return entries[0]
    return into
