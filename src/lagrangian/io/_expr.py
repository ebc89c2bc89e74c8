"""The expression language's old address: the safe parser is the model's language and lives in
:mod:`lagrangian.model._expr`. This name is that same module (one module object, so that a patch
through either name reaches both), kept for code that imports ``lagrangian.io._expr``."""

import sys

from ..model import _expr

sys.modules[__name__] = _expr
