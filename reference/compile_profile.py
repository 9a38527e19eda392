"""Where numba's compile time goes: seconds per dispatcher and per phase (docs/benchmarks.md §18).

While a :class:`CompileProfile` listens, numba's ``numba:compile`` events (one per dispatcher and signature),
its ``numba:run_pass`` events (one per compiler pass: bytecode, IR inlining, type inference, lowering, …)
and timers around the LLVM steps of numba's code library form one stack, and every second is charged to the
frame on top of it: a kernel compiled inside another's type inference is charged to itself, not to its caller
as well, and the LLVM work done while a pass runs (a callee's machine code, say) is charged to LLVM. The LLVM
steps timed are those of ``numba.core.codegen.CPUCodeLibrary`` (numba 0.6x): the function passes run on
each freshly lowered module, the module passes run after the callees' modules are linked in, the machine
code, and parsing, linking and cloning modules.

A deck's first run, from an empty cache (``XDG_CACHE_HOME=$(mktemp -d)``)::

    with CompileProfile() as profile:
        load_deck("models/three_bar.toml").domain.solve(results_path="results.h5")
    print(profile.table())

No kernel module imports this one: editing it recompiles nothing (:mod:`reference.kernel_cache`).
"""

from __future__ import annotations

import time
from collections import defaultdict

import numba.core.event as event
from numba.core import codegen

LLVM_STEPS = {"_optimize_functions": "function passes", "_optimize_final_module": "module passes",
              "_finalize_final_module": "machine code", "add_ir_module": "parse and link",
              "_get_module_for_linking": "parse and link", "serialize_using_object_code": "parse and link"}
"""The timed methods of numba's ``CPUCodeLibrary`` and the LLVM phase each is charged to."""


class CompileProfile:
    """Exclusive compile seconds by (dispatcher, phase), and each dispatcher's signatures, while it listens
    (``with CompileProfile() as profile:``); module docstring.

    ``seconds[name][phase]``: wall seconds [s] charged to the dispatcher ``name`` (``module.qualname``) in
    ``phase`` (``"numba: <pass name>"`` or ``"llvm: <step>"``); ``signatures[name]``: its compiled argument
    types.
    """

    def __init__(self):
        self.seconds: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
        self.signatures: dict[str, set[str]] = defaultdict(set)
        self._stack: list[tuple[str, str]] = []
        self._last = 0.0
        self._saved: dict[str, object] = {}
        self._listeners: list = []

    def _charge(self) -> None:
        now = time.perf_counter()
        if self._stack:
            kind, label = self._stack[-1]
            owner = next((name for k, name in reversed(self._stack) if k == "compile"), "(outside a dispatcher)")
            phase = "numba: other" if kind == "compile" else f"{kind}: {label}"
            self.seconds[owner][phase] += now - self._last
        self._last = now

    def _push(self, kind: str, label: str) -> None:
        self._charge()
        self._stack.append((kind, label))

    def _pop(self) -> None:
        self._charge()
        self._stack.pop()

    def _timed(self, method, phase: str):
        def timed(library, *args, **kwargs):
            self._push("llvm", phase)
            try:
                return method(library, *args, **kwargs)
            finally:
                self._pop()
        return timed

    def __enter__(self) -> "CompileProfile":
        profile = self

        class Compile(event.Listener):
            def on_start(self, ev):
                func = ev.data["dispatcher"].py_func
                name = f"{func.__module__}.{func.__qualname__}"
                profile.signatures[name].add(str(ev.data["args"]))
                profile._push("compile", name)

            def on_end(self, ev):
                profile._pop()

        class Pass(event.Listener):
            def on_start(self, ev):
                profile._push("numba", ev.data["name"].split(" [")[0])

            def on_end(self, ev):
                profile._pop()

        self._listeners = [("numba:compile", Compile()), ("numba:run_pass", Pass())]
        for kind, listener in self._listeners:
            event.register(kind, listener)
        library = codegen.CPUCodeLibrary
        for method, phase in LLVM_STEPS.items():
            self._saved[method] = library.__dict__[method]
            setattr(library, method, self._timed(library.__dict__[method], phase))
        self._last = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        for kind, listener in self._listeners:
            event.unregister(kind, listener)
        for method, original in self._saved.items():
            setattr(codegen.CPUCodeLibrary, method, original)
        self._saved.clear()

    def phases(self) -> dict[str, float]:
        """Seconds [s] per phase, summed over the dispatchers."""
        total: dict[str, float] = defaultdict(float)
        for by_phase in self.seconds.values():
            for phase, s in by_phase.items():
                total[phase] += s
        return dict(total)

    def table(self, rows: int = 20) -> str:
        """The dispatchers that took longest (the last 70 characters of the name; signatures, front end and LLVM
        seconds), then the phases."""
        lines = [f"{'dispatcher':70s} {'sigs':>4s} {'numba s':>8s} {'llvm s':>7s}"]
        split = {name: (sum(s for p, s in by.items() if p.startswith("numba")),
                        sum(s for p, s in by.items() if p.startswith("llvm"))) for name, by in self.seconds.items()}
        for name in sorted(split, key=lambda n: -sum(split[n]))[:rows]:
            lines.append(f"{name[-70:]:70s} {len(self.signatures.get(name, ())):4d} "
                         f"{split[name][0]:8.2f} {split[name][1]:7.2f}")
        phases = self.phases()
        total = sum(phases.values()) or 1.0
        lines += [f"{phase:60s} {s:8.2f} s {100 * s / total:5.1f} %"
                  for phase, s in sorted(phases.items(), key=lambda item: -item[1])]
        return "\n".join(lines)

