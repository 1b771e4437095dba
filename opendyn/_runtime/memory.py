"""How much memory this process may still allocate: the smallest of what the system, the
process's limits and its control group allow.

    room = min( MemAvailable                              (Linux; elsewhere the physical memory)
                RLIMIT_AS - VmSize,  RLIMIT_DATA - VmData (ulimit -v, ulimit -d)
                memory.max - memory.current               (the cgroup and each one above it) )

MemAvailable alone misses the limits that batch systems, login nodes and containers set: under
`ulimit -v 1000000` a run whose record fits in MemAvailable would be refused its post-processing
by a MemoryError after the whole run.
"""

from __future__ import annotations

import os
import pathlib

_CGROUP = pathlib.Path("/sys/fs/cgroup")
# a cgroup v1 "no limit" is a huge number, not "max"
_NO_LIMIT = 2**60


def available_memory():
    """(bytes, what): the memory this process may still allocate and what sets it (for a
    message: "memory available", "the address-space limit (ulimit -v)", ...), or None where
    nothing says."""
    rooms = [_system(), *_process_limits(), *_cgroups()]
    rooms = [room for room in rooms if room is not None]
    return min(rooms, key=lambda room: room[0]) if rooms else None


def _system():
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024, "memory available"
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")), "memory"
    except (AttributeError, OSError, ValueError):
        return None


def _process_status():
    """{field: bytes} of /proc/self/status's Vm lines (VmSize, VmData, ...); {} elsewhere."""
    sizes = {}
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Vm") and line.rstrip().endswith("kB"):
                    name, value = line.split(":", 1)
                    sizes[name] = float(value.split()[0]) * 1024
    except OSError:
        pass
    return sizes


def _process_limits():
    """The room under the address-space and data-segment limits, where set."""
    try:
        import resource
    except ImportError:  # not on Windows
        return
    used = _process_status()
    for limit, field, what in (
        (resource.RLIMIT_AS, "VmSize", "the address-space limit (ulimit -v)"),
        (resource.RLIMIT_DATA, "VmData", "the data-size limit (ulimit -d)"),
    ):
        soft, _ = resource.getrlimit(limit)
        if soft != resource.RLIM_INFINITY and soft > 0:
            yield max(0.0, soft - used.get(field, 0.0)), what


def _cgroups():
    """The room under the memory limit of this process's control group and of every group
    above it (v2: memory.max, memory.current; v1: memory.limit_in_bytes, usage_in_bytes)."""
    try:
        lines = pathlib.Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        return
    for line in lines:
        _, controllers, path = line.split(":", 2)
        if controllers == "":  # v2, the unified hierarchy
            root, files = _CGROUP, ("memory.max", "memory.current")
        elif "memory" in controllers.split(","):
            root, files = _CGROUP / "memory", ("memory.limit_in_bytes", "memory.usage_in_bytes")
        else:
            continue
        folder = root / path.lstrip("/")
        while True:
            room = _cgroup_room(folder, *files)
            if room is not None:
                yield room, f"the control group's memory limit ({folder / files[0]})"
            if folder == root or root not in folder.parents:
                break
            folder = folder.parent


def _cgroup_room(folder, limit_file, usage_file):
    try:
        limit = (folder / limit_file).read_text().strip()
        usage = float((folder / usage_file).read_text().strip())
    except (OSError, ValueError):
        return None
    if limit == "max" or not limit.isdigit() or int(limit) >= _NO_LIMIT:
        return None
    return max(0.0, int(limit) - usage)
