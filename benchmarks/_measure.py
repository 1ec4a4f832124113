"""Run a snippet in a fresh Python process and report wall time and peak RSS (shared by benchmarks)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

_WRAPPER = """
import json, resource, time
t0 = time.perf_counter()
{body}
print("__MEASURE__" + json.dumps({{"seconds": time.perf_counter() - t0,
      "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""


def measure(body: str, timeout: float = 3600) -> dict:
    """{'seconds', 'peak_mib'} of ``body`` run in a new interpreter, or {'error': ...}."""
    code = _WRAPPER.format(body=textwrap.indent(textwrap.dedent(body), ""))
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout
    )
    for line in proc.stdout.splitlines():
        if line.startswith("__MEASURE__"):
            return json.loads(line[len("__MEASURE__") :])
    return {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
