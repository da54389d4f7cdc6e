"""Type stubs of crossaudit's native module (PyO3). Use the functions of
the `crossaudit` package, which wrap these in arrays and DataFrames."""

from os import PathLike
from pathlib import Path
from typing import List, Optional, Tuple, Union

_Path = Union[str, PathLike[str]]

class CrossauditError(Exception):
    """An error crossaudit reports, with the command line's message."""

def build() -> str: ...
def load_design(path: _Path) -> str: ...
def export(design: _Path, out: _Path, data: Optional[_Path] = None, exploratory: bool = False) -> str: ...
def score(dir: _Path, workers: Optional[int] = None) -> str: ...
def run(
    design: _Path,
    out: _Path,
    data: Optional[_Path] = None,
    workers: Optional[int] = None,
    exploratory: bool = False,
    device: str = "cpu",
) -> str: ...
def analyze(
    design: _Path, cells: _Path, out: Optional[_Path] = None, compare_intervals: bool = False
) -> Tuple[str, str, bool, str, str, List[str]]: ...
def audit_split(
    split: _Path, data: _Path, out: _Path, design: Optional[_Path] = None, min_run: int = 100
) -> Tuple[List[Path], bool]: ...
