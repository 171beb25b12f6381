"""Suite-wide settings.

torch's OpenMP threads busy-wait between parallel regions by default; on a small shared
machine (CI has 2 cores and the tests start worker processes) that stalls everything
else. Passive waiting must be chosen before torch loads its OpenMP runtime, hence here.
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
