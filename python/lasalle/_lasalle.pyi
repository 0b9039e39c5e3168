"""Type stubs of the native module ``lasalle._lasalle`` (the Python API is ``lasalle``)."""

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

known_methods: str

class LasalleError(Exception): ...

class ModelError(LasalleError):
    file: Optional[str]
    line: Optional[int]
    column: Optional[int]
    diagnostic: str

class GuardError(LasalleError):
    guard: str
    t: float
    state: npt.NDArray[np.float64]

def builtin_models() -> List[str]: ...
def model_text(arg: str) -> Tuple[str, str]: ...

class NativeModel:
    def __init__(self, text: str, path: str, backend_name: str = "jit") -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def text(self) -> str: ...
    @property
    def backend(self) -> str: ...
    @property
    def dim(self) -> int: ...
    @property
    def state_names(self) -> List[str]: ...
    @property
    def param_names(self) -> List[str]: ...
    @property
    def integrals(self) -> List[str]: ...
    @property
    def gain_names(self) -> List[str]: ...
    @property
    def event_names(self) -> List[str]: ...
    @property
    def event_terminal(self) -> List[bool]: ...
    @property
    def point_names(self) -> List[str]: ...
    @property
    def load_seconds(self) -> float: ...
    def point(self, name: str) -> npt.NDArray[np.float64]: ...
    def get_param(self, name: str) -> Union[float, npt.NDArray[np.float64]]: ...
    def param_shape(self, name: str) -> List[int]: ...
    def set_param(self, name: str, values: Sequence[float]) -> None: ...
    def presets(self) -> Dict[str, Dict[str, Any]]: ...
    def solve(
        self,
        y0: npt.NDArray[np.float64],
        t0: float,
        t1: float,
        method: str,
        dt: Optional[float],
        rtol: Optional[float],
        atol: Optional[float],
        gains: Union[str, Sequence[float]],
        params: Dict[str, Sequence[float]],
        every: Optional[int],
        max_steps: Optional[int],
        max_drift: Optional[float],
        t_eval: Optional[Sequence[float]],
        main_thread: bool = False,
    ) -> Dict[str, Any]: ...
    def solve_many(
        self,
        y0s: npt.NDArray[np.float64],
        t0: float,
        t1: float,
        method: str,
        dt: Optional[float],
        rtol: Optional[float],
        atol: Optional[float],
        gains: Union[str, Sequence[float]],
        params: Dict[str, npt.NDArray[np.float64]],
        every: Optional[int],
        max_steps: Optional[int],
        max_drift: Optional[float],
        t_eval: Optional[Sequence[float]],
        threads: int,
        lanes: int,
        main_thread: bool = False,
    ) -> List[Union[Dict[str, Any], str]]: ...
    def normal_form(
        self,
        order: int,
        precision: str,
        params: Dict[str, float],
        at: Union[str, Sequence[float], None],
        resonant: bool,
        resonance_tol: float,
        max_rel_error: float,
        error_estimate: str,
    ) -> str: ...
    def stability(
        self,
        file: str,
        casimir: Optional[float],
        at: Optional[Sequence[float]],
        range: Optional[Tuple[float, float]],
        levels: int,
        lyapunov: Optional[str],
        radius: Optional[float],
        time_bound: Sequence[Tuple[float, float]],
        order: Optional[int],
        for_time: Sequence[float],
        outer_ratio: Optional[float],
        remainder_degree: Optional[int],
        metric: str,
        equilibrium: Union[str, Sequence[float], None],
        validate: bool,
        horizon: float,
        certified: bool,
    ) -> str: ...
