"""Run several command-line invocations in one process (``python -m tests.cli_cases``).

Reads a JSON list of ``[module, [arg, ...]]`` on stdin, calls each module's ``main()`` with
those arguments exactly as its console script does, and prints one JSON list of
``{"rc": exit status, "stderr": text}``. The acceptance test of bad input uses it to run many
failing invocations of the real commands without paying a process start for each.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import sys

from hydra.core.global_hydra import GlobalHydra


def run_case(module: str, args: list[str]) -> dict:
    """Exit status and standard error of ``module.main()`` with ``args`` on the command line."""
    main = importlib.import_module(module).main
    err = io.StringIO()
    sys.argv = [module, *args]
    rc = 0
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            main()
        except SystemExit as exc:
            rc = exc.code if isinstance(exc.code, int) else 1
        except BaseException as exc:  # noqa: BLE001 - reported to the test, never swallowed
            import traceback

            traceback.print_exc(file=err)
            rc = f"raised {type(exc).__name__}"
    GlobalHydra.instance().clear()
    return {"rc": rc, "stderr": err.getvalue()}


if __name__ == "__main__":
    print(json.dumps([run_case(m, a) for m, a in json.load(sys.stdin)]))
