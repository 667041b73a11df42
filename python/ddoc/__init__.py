"""ddoc: data-driven iterative optimal control of switched systems (Algorithm 1 of Chen, Li & Braun,
RA-L 2023) from Python. A thin layer over the C++ engine (the extension module ddoc._ddoc), plus
to_dataframe and robustness_map (which runs tools/robustness_map); see docs/python.md."""
from ._interpreter import check_interpreter as _check_interpreter

_check_interpreter()  # NumPy and an interpreter the module was built for, or a clear ImportError
from ._ddoc import *  # noqa: F401,F403,E402  (the bound C++ API)
from ._map import robustness_map  # noqa: F401,E402
from ._tables import to_dataframe  # noqa: F401,E402
