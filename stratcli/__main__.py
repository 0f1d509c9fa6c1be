"""Entry point of `stratplan` and `python -m stratcli`."""

import os

# Planning multiplies matrices of a few dozen rows, where BLAS threads only add overhead and
# take the cores that compare-sequences' worker processes need (Sim 4 energy comparison on 2
# processes: 7.4 s with OpenBLAS threads, 6.7 s without, and a third less CPU time on one).
# The variables only work before numpy is first imported; a value the user set wins.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas() -> None:
    for var in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(var, "1")


def main() -> None:
    single_threaded_blas()
    from .cli import app

    app(prog_name="stratplan")


if __name__ == "__main__":
    main()
