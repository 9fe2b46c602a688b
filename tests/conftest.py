"""The suite's environment: runs compile every kernel they need in their own process,
without a compile helper beside them (`dda.jit.compile_helper`; its tests start their
own), so that the suite's processes are the workers pytest starts."""

import os

os.environ.setdefault("DDA_COMPILE_HELPER", "0")
