"""Run a snippet in a fresh Python process and report wall time and peak RSS (shared by benchmarks)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

_WRAPPER = """
import json, resource, time
extra = {{}}
t0 = time.perf_counter()
{body}
print("__MEASURE__" + json.dumps({{"seconds": time.perf_counter() - t0,
      "peak_mib": peak_mib(), **extra}}))
"""

# Linux keeps ru_maxrss across fork + exec, so a child of a big parent would report the
# parent's peak; VmHWM (/proc/self/status) belongs to the new process image only.
_PEAK = """
import resource
def peak_mib():
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
"""


def measure(body: str, timeout: float = 3600, env: dict | None = None) -> dict:
    """{'seconds', 'peak_mib'} of ``body`` run in a new interpreter, or {'error': ...}.

    ``body`` can call ``peak_mib()`` (the process's peak RSS so far, MiB) itself.
    ``body`` may put more results (JSON-serialisable) in the dict ``extra``; they are merged
    into the answer. ``env``: extra environment variables for the child.
    """
    import os

    code = _PEAK + _WRAPPER.format(body=textwrap.indent(textwrap.dedent(body), ""))
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=timeout,
        env={**os.environ, **(env or {})},
    )
    for line in proc.stdout.splitlines():
        if line.startswith("__MEASURE__"):
            return json.loads(line[len("__MEASURE__") :])
    return {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
