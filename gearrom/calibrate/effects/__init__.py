"""The built-in effects of the diagnosis library, one module each (see :mod:`gearrom.calibrate.registry`).

=======================  =========================================================================
``eccentricity``         gear runout: once-per-rev kinematic error through the drivetrain
``encoder_eccentricity`` once-per-rev angle error of one encoder (measurement only)
``pitch_error``          one displaced tooth, followed through its whole engagement
``tip_relief``           tip relief of one gear beyond the drawing (mesh table change)
``lead_crowning``        lead crowning of the pair (mesh table change)
``helix_slope``          helix slope deviation of the pair (mesh table change)
``torsional_mode``       a mis-tuned rig parameter and the mode it moves (re-simulation)
=======================  =========================================================================

Adding an effect: write a module like these (its spec, candidate fit, evidence and config mapping, ending
with ``register(Plugin())``) and import it below; a module outside the package registers the same way.
"""
# registration order = the order candidates are tried and listed
from gearrom.calibrate.effects import eccentricity  # noqa: F401
from gearrom.calibrate.effects import pitch_error  # noqa: F401
from gearrom.calibrate.effects import encoder_eccentricity  # noqa: F401
from gearrom.calibrate.effects import tip_relief  # noqa: F401
from gearrom.calibrate.effects import lead_crowning  # noqa: F401
from gearrom.calibrate.effects import helix_slope  # noqa: F401
from gearrom.calibrate.effects import torsional_mode  # noqa: F401
