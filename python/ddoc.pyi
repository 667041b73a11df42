"""Type stub of the ddoc Python package (python/ddoc_module.cc, python/ddoc/). See docs/python.md."""
from enum import Enum
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Array = npt.NDArray[np.float64]

class SolveInterrupted(KeyboardInterrupt):
    """Ctrl-C during Learner.solve (.result: the SolveResult of the trials done so far),
    run_hopper (the partial result dict) or robustness_map (the finished cases)."""
    result: Any

class Bounds:
    """Input bounds (6), duration bounds (7) and a box on the final time."""
    u_min: Array
    u_max: Array
    duration_min: Array
    duration_max: Array
    final_time_min: float
    final_time_max: float
    def __init__(self, u_min: ArrayLike = ..., u_max: ArrayLike = ...,
                 duration_min: ArrayLike = ..., duration_max: ArrayLike = ...,
                 final_time_min: float = 0.0, final_time_max: float = ...) -> None: ...
    def fix_final_time(self, t_final: float) -> None: ...
    @property
    def final_time_bounded(self) -> bool: ...

class System:
    """A switched system (f_k, g_k, h_k), evaluated with the engine's checks."""
    @property
    def num_modes(self) -> int: ...
    @property
    def input_dim(self) -> int: ...
    def state_dim(self, k: int) -> int: ...
    def surface_dim(self, k: int) -> int: ...
    def flow(self, k: int, x: ArrayLike, u: ArrayLike) -> Array: ...
    def flow_derivatives(self, k: int, x: ArrayLike, u: ArrayLike) -> Tuple[Array, Array]: ...
    def reset(self, k: int, x: ArrayLike) -> Array: ...
    @property
    def prefers_batch(self) -> bool:
        """True when the backward pass evaluates the flow once per mode (a batch callable)."""
    def flow_batch(self, k: int, X: ArrayLike, U: ArrayLike) -> Array:
        """Xdot (N, n_k) at the N points, rows of X (N, n_k) and U (N, m)."""
    def flow_derivatives_batch(self, k: int, X: ArrayLike, U: ArrayLike) -> Tuple[Array, Array]:
        """(FX (N, n_k, n_k), FU (N, n_k, m)) at the N points."""

class LinearSystem(System):
    """xdot = A_k x + B_k u, x+ = E_k x; entirely in C++. B None: m = 0; E None: identity."""
    def __init__(self, A: Sequence[ArrayLike], B: Optional[Sequence[ArrayLike]] = None,
                 E: Optional[Sequence[ArrayLike]] = None) -> None: ...

BatchFlow = Callable[[int, Array, Array], ArrayLike]  # (k, X (N, n_k), U (N, m)) -> (N, n_k)
BatchFlowDerivatives = Callable[[int, Array, Array], Tuple[ArrayLike, ArrayLike]]
BatchRunning = Callable[[int, Array, Array], ArrayLike]  # (k, X, U) -> l (N,)
BatchRunningDerivatives = Callable[[int, Array, Array], Tuple[ArrayLike, ArrayLike, ArrayLike,
                                                              ArrayLike, ArrayLike]]

class CallbackSystem(System):
    """A switched system of Python callables; missing derivatives by central differences.
    flow_batch / flow_derivatives_batch (instead of or beside flow): all the points of a mode
    in one call, (N, n_k) / (N, n_k, n_k) and (N, n_k, m) arrays."""
    def __init__(self, state_dims: Sequence[int], input_dim: int,
                 flow: Optional[Callable[[int, Array, Array], ArrayLike]] = None,
                 reset: Optional[Callable[[int, Array], ArrayLike]] = None,
                 flow_derivatives: Optional[Callable[[int, Array, Array],
                                                     Tuple[ArrayLike, ArrayLike]]] = None,
                 reset_derivative: Optional[Callable[[int, Array], ArrayLike]] = None,
                 surface_dims: Sequence[int] = ...,
                 surface: Optional[Callable[[int, Array], ArrayLike]] = None,
                 surface_derivative: Optional[Callable[[int, Array], ArrayLike]] = None,
                 cycle_reset: bool = False, fd_step: float = 1e-6,
                 flow_batch: Optional[BatchFlow] = None,
                 flow_derivatives_batch: Optional[BatchFlowDerivatives] = None) -> None: ...

class Cost:
    """Running costs l_k(x, u) and switching costs phi_k(x)."""
    def running(self, k: int, x: ArrayLike, u: ArrayLike) -> float: ...
    def switching(self, k: int, x: ArrayLike) -> float: ...
    @property
    def prefers_batch(self) -> bool:
        """True when the backward pass and the cost evaluation call the running cost once per
        mode (a batch callable)."""
    def running_batch(self, k: int, X: ArrayLike, U: ArrayLike) -> Array:
        """l (N,) at the N points, rows of X (N, n_k) and U (N, m)."""
    def running_derivatives_batch(self, k: int, X: ArrayLike, U: ArrayLike) -> Tuple[
            Array, Array, Array, Array, Array]:
        """(LX (N, n_k), LU (N, m), LXX (N, n_k, n_k), LUU (N, m, m), LUX (N, m, n_k))."""

class QuadraticCost(Cost):
    """l_k = 1/2 (x-r_k)'Q_k(x-r_k) + 1/2 u'R_k u + u'N_k(x-r_k) + rho_k,
    phi_k = 1/2 (x-s_k)'S_k(x-s_k)."""
    def __init__(self, Q: Sequence[ArrayLike], R: Sequence[ArrayLike],
                 S: Optional[Sequence[ArrayLike]] = None, r: Optional[Sequence[ArrayLike]] = None,
                 s: Optional[Sequence[ArrayLike]] = None,
                 rho: Optional[Sequence[float]] = None,
                 N: Optional[Sequence[ArrayLike]] = None) -> None: ...

class CallbackCost(Cost):
    """A cost of Python callables; missing derivatives by central differences.
    running_batch / running_derivatives_batch (instead of or beside running): all the points of
    a mode in one call."""
    def __init__(self, running: Optional[Callable[[int, Array, Array], float]] = None,
                 switching: Optional[Callable[[int, Array], float]] = None,
                 running_derivatives: Optional[Callable[[int, Array, Array], Tuple[
                     ArrayLike, ArrayLike, ArrayLike, ArrayLike, ArrayLike]]] = None,
                 switching_derivatives: Optional[Callable[[int, Array],
                                                          Tuple[ArrayLike, ArrayLike]]] = None,
                 fd_step: float = 1e-6, fd_hessian_step: float = 1e-4,
                 running_batch: Optional[BatchRunning] = None,
                 running_derivatives_batch: Optional[BatchRunningDerivatives] = None) -> None: ...

class Problem:
    """The problem (9)-(10); validates on construction (ValueError)."""
    bounds: Bounds
    surface_weights: Array
    def __init__(self, system: System, cost: Cost, bounds: Bounds,
                 surface_weights: Optional[ArrayLike] = None) -> None: ...
    @property
    def num_modes(self) -> int: ...
    @property
    def input_dim(self) -> int: ...
    def validate(self) -> None: ...

class BackwardEquation(Enum):
    LYAPUNOV = ...
    RICCATI = ...

class BackwardIntegrator(Enum):
    MIDPOINT = ...
    RK4 = ...

class BackwardPassSettings:
    equation: BackwardEquation
    integrator: BackwardIntegrator
    cyclic_value: float
    terminal_event: bool
    box_aware: bool
    time_curvature: bool
    use_previous_du: bool
    psd_switching_hessians: bool
    max_substeps: int
    min_substeps: int
    def __init__(self) -> None: ...

class SwitchingTimeSettings:
    relative_regularization: float
    max_duration_step: float
    def __init__(self) -> None: ...

class OnlineControllerSettings:
    interpolate: bool
    warm_start: bool
    def __init__(self) -> None: ...

class Acceptance(Enum):
    SUFFICIENT_DECREASE = ...
    PREDICTED_DECREASE = ...

class AlphaAfterAccept(Enum):
    RESET = ...
    GROW = ...
    RATIO = ...

class LearnerSettings:
    """LearnerSettings() is the 'default' preset; LearnerSettings.paper() the 'paper' one."""
    acceptance: Acceptance
    c: float
    gamma: float
    interpolate_backtracking: bool
    alpha_initial: float
    alpha_after_accept: AlphaAfterAccept
    alpha_min: float
    convergence_tolerance: float
    step_convergence: bool
    epsilon: float
    delta_i: int
    optimality_tolerance: float
    regularization_min: float
    failure_raises: int
    curvature_scale_min: float
    max_trials: int
    max_samples: int
    backward: BackwardPassSettings
    switching: SwitchingTimeSettings
    controller: OnlineControllerSettings
    def __init__(self) -> None: ...
    @staticmethod
    def paper() -> LearnerSettings: ...
    @staticmethod
    def preset(name: str) -> LearnerSettings: ...

class ModeTrajectory:
    t: Array  # (N,)
    x: Array  # (n_k, N)
    u: Array  # (m, N)

class Trajectory:
    """One trial: modes (ModeTrajectory per mode), T (K,) switching instants, x0."""
    modes: List[ModeTrajectory]
    T: Array
    x0: Array
    def __init__(self, t: Sequence[ArrayLike], x: Sequence[ArrayLike],
                 u: Sequence[ArrayLike]) -> None:
        """Per mode k: t[k] (N_k,), x[k] (n_k, N_k), u[k] (m, N_k); T(k) = t[k][-1]."""
        ...

class Policy:
    """The law of one trial, given to Plant.run (valid only during that call)."""
    input_dim: int
    def begin_trial(self) -> None: ...
    def planned_duration(self, k: int) -> float: ...
    def step(self, k: int, t_since_mode_start: float, x: ArrayLike) -> Array: ...

class Plant:
    """Runs one trial of a policy; subclass it in Python and define run(x0, policy)."""
    def __init__(self) -> None: ...
    def run(self, x0: ArrayLike, policy: Policy) -> Trajectory: ...

class ModelPlant(Plant):
    """The engine's RK4 plant of a System (ddoc::ModelPlant)."""
    def __init__(self, system: System, bounds: Bounds, dt: float = 1e-3) -> None: ...

class SolveResult:
    status: str  # 'converged', 'line_search_failed' or 'max_trials'
    trials: int
    iterations: int
    cost: float
    T: Array
    optimality: float
    optimality_inputs: float
    optimality_times: float
    cost_history: Array
    stop_reason: str  # why it stopped, with the figures of the deciding test
    interrupted: bool

class Learner:
    """Algorithm 1 on a Problem."""
    def __init__(self, problem: Problem, settings: LearnerSettings = ...) -> None: ...
    def solve(self, x0: ArrayLike, durations: ArrayLike,
              u0: Union[None, ArrayLike, Callable[[int, float, Array], ArrayLike]] = None,
              plant: Union[None, System, Plant] = None, method: str = "alg1", dt: float = 1e-3,
              progress: Optional[Callable[[Dict[str, Any]], None]] = None) -> SolveResult: ...
    @property
    def nominal(self) -> Trajectory: ...
    @property
    def status(self) -> str: ...
    @property
    def trials(self) -> int: ...
    @property
    def iteration(self) -> int: ...
    @property
    def settings(self) -> LearnerSettings: ...
    def feedback_law(self, alpha: float = 1.0) -> List[Dict[str, Array]]:
        """Per mode: t (N,), x (N, n), u (N, m), u_ff (N, m), K (N, m, n); u = u_ff + K x."""
        ...


HAVE_RENDER: bool
"""run_hopper can write PNG frames (the build has OSMesa rendering); with run_hopper only."""

Push = Union[str, Tuple[float, float, float], Tuple[int, float, float, float]]

def run_hopper(scenario: str, method: str = "", hops: Optional[int] = None,
               seconds: Optional[float] = None, robot: str = "", model_mjcf: str = "",
               pushes: Sequence[Push] = ..., no_pushes: bool = False, preset: str = "",
               offline_latency: Union[float, str, None] = None, log_every: int = 1,
               progress: Optional[Callable[[Dict[str, Any]], None]] = None,
               render_dir: str = "", width: int = 640, height: int = 480,
               fps: float = 60.0, law_cache: str = "",
               substep_events: bool = False,
               identify: Optional[bool] = None,
               identify_terms: Optional[bool] = None,
               identify_terms_acted: str = "") -> Dict[str, Any]:
    """Runs a ddoc-hopper scenario (built with the MuJoCo application only) with the command
    line's overrides (method, hops, seconds, robot, model_mjcf, pushes as (time, force, duration),
    (hop, phase, force, duration) or the --push strings, no_pushes, preset "default" | "paper",
    offline_latency, log_every, law_cache, substep_events, identify, identify_terms,
    identify_terms_acted "all" | "none" | "b_leg,b_hip,j_body,c_d,slope"); progress(row) after
    every hop; PNG frames into
    render_dir when HAVE_RENDER. Returns the columns of hops.csv as NumPy arrays, 'trajectory'
    (the columns of trajectory.csv), method, fell, fall_reason, sim_time, frames, initial_law,
    resolves.
    Ctrl-C raises SolveInterrupted with the partial result; a controller failure or a
    non-finite MuJoCo state raises RunFailed with it; MuJoCo's warnings are RuntimeWarnings."""
    ...

class RunFailed(RuntimeError):
    """run_hopper ended early; .end is "error" or "nonfinite_state" (ddoc-hopper's exits 1 and
    6), .result the table of the hops completed before."""
    result: Optional[Dict[str, Any]]
    end: Optional[str]

def to_dataframe(table: Dict[str, Any]) -> Any:
    """The dict of equal-length arrays `table` as a pandas DataFrame (other plain values in
    .attrs); ImportError when pandas is not installed."""
    ...

def robustness_map(out: str, maps: Union[str, Sequence[str]] = ("mass", "push"),
                   methods: Union[str, Sequence[str]] = ("alg1", "ocfb", "mrl"),
                   shard: Union[None, str, Tuple[int, int]] = None, jobs: Optional[int] = None,
                   preset: str = "default", hops: Optional[int] = None,
                   tool: Optional[str] = None, hopper: Optional[str] = None,
                   as_frame: bool = False, verbose: bool = False,
                   **grid: Any) -> Dict[str, Any]:
    """Runs tools/robustness_map into `out` (grid options as keywords: masses, drags, speeds,
    robots, forces, durations, phases, push_hop, push_speed, tolerance) and returns
    {map: the columns of OUT/<map>_map.csv as NumPy arrays} (DataFrames with as_frame=True).
    Ctrl-C stops the tool and raises SolveInterrupted with the finished cases in .result."""
    ...
