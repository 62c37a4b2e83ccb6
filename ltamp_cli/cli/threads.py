"""One thread for numerics: the GPs and samplers of ltamp are small.

Small GP fits and predictions run several times slower on two threads than on one (OpenMP
and OpenBLAS oversubscription, see the field facts), so commands limit every thread pool
already loaded (numpy's and scipy's OpenBLAS, torch's OpenMP) to one thread. Call it after
the imports whose pools should be limited: pools loaded later keep their defaults.
"""

from __future__ import annotations

import sys


def use_one_thread() -> None:
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)
