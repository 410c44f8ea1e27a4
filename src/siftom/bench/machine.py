"""Where a benchmark's numbers were measured: one record, written in the forms the result files use.

* ``results/NAME.json`` and the whole-trial rows (``siftom bench reproduce``, ``siftom bench
  trials``): ``cpu_count``, ``platform``, ``machine``, ``python``;
* the service benchmarks (``siftom bench robots``, ``siftom bench hostile``): ``version``, ``cpus``,
  ``processor``, ``system``, ``python``, ``load_avg_before``;
* ``siftom bench latency``: ``cpus``, ``processor``, ``load_1min``.
"""

from __future__ import annotations

import os
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

Form = Literal["results", "service", "latency"]


def cpu_name() -> str:
    """The processor's model name from ``/proc/cpuinfo`` ('' where there is none)."""
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8")
    except OSError:
        return ""
    return next((ln.split(":", 1)[1].strip() for ln in text.splitlines() if ln.startswith("model name")), "")


@dataclass(frozen=True)
class Machine:
    """A machine and its load when a benchmark started; None where a result file does not say.

    Attributes:
        cpus: CPU count.
        processor: the processor's name (or its architecture where the name is unknown).
        platform: the operating system, ``platform.platform(terse=True)``.
        arch: the architecture, ``platform.machine()``.
        python: the Python version.
        version: siftom's version.
        load_avg: the 1, 5 and 15 minute load averages, rounded to 0.01.
    """

    cpus: int | None = None
    processor: str | None = None
    platform: str | None = None
    arch: str | None = None
    python: str | None = None
    version: str | None = None
    load_avg: tuple[float, ...] | None = None

    @classmethod
    def here(cls) -> Machine:
        """This machine, now."""
        from siftom import __version__

        return cls(cpus=os.cpu_count(), processor=cpu_name() or platform.machine(),
                   platform=platform.platform(terse=True), arch=platform.machine(),
                   python=platform.python_version(), version=__version__,
                   load_avg=tuple(round(x, 2) for x in os.getloadavg()))

    def summary(self) -> str:
        """'; 2 CPUs (AMD EPYC), load 1.52' for a console line ('' for an empty record)."""
        if self.cpus is None:
            return ""
        load = f", load {self.load_avg[0]:g}" if self.load_avg else ""
        return f"; {self.cpus} CPUs ({self.processor or 'unknown processor'}){load}"

    def to_json(self, form: Form = "service") -> dict[str, Any]:
        """The ``machine`` entry of a result file of ``form`` (module doc)."""
        if form == "results":
            return {"cpu_count": self.cpus, "platform": self.platform, "machine": self.arch, "python": self.python}
        if form == "latency":
            return {"cpus": self.cpus, "processor": self.processor,
                    "load_1min": self.load_avg[0] if self.load_avg else None}
        return {"version": self.version, "cpus": self.cpus, "processor": self.processor, "system": self.platform,
                "python": self.python, "load_avg_before": self.load_avg}

    @classmethod
    def from_json(cls, data: object) -> Machine:
        """Read any of the forms (an empty record from something that is not a JSON object)."""
        if not isinstance(data, dict):
            return cls()
        load = data.get("load_avg_before")
        if load is None and data.get("load_1min") is not None:
            load = [data["load_1min"]]
        return cls(cpus=data.get("cpus", data.get("cpu_count")), processor=data.get("processor"),
                   platform=data.get("system", data.get("platform")), arch=data.get("machine"),
                   python=data.get("python"), version=data.get("version"),
                   load_avg=None if load is None else tuple(load))
