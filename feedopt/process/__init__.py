"""Process stage of feedopt: engagement -> mechanistic milling forces (see shared/design.md).

Thesis section 3.4 (Algorithm 1) and 3.6.1 (Eq. 3.24-3.25, Tables 3.2-3.3).
"""

from feedopt.process.averages import average_forces, average_torque
from feedopt.process.calibration import (
    SlotForceRow,
    SpeedCalibration,
    calibrate,
    calibration_table,
    read_slot_forces,
)
from feedopt.process.coefficients import (
    CoefficientTable,
    CuttingCoefficients,
    load_coefficients,
    save_coefficients,
)
from feedopt.process.engagement import (
    Engagement,
    peripheral_engagement,
    radial_depth_profile,
    slot_engagement,
)
from feedopt.process.forces import (
    ForceSplit,
    feed_from_feed_per_tooth,
    feed_per_tooth,
    milling_forces,
    rotation_angles,
    spindle_power,
)
from feedopt.process.tool import Tool, load_tool

__all__ = [
    "CoefficientTable",
    "CuttingCoefficients",
    "Engagement",
    "ForceSplit",
    "SlotForceRow",
    "SpeedCalibration",
    "Tool",
    "average_forces",
    "average_torque",
    "calibrate",
    "calibration_table",
    "feed_from_feed_per_tooth",
    "feed_per_tooth",
    "load_coefficients",
    "load_tool",
    "milling_forces",
    "peripheral_engagement",
    "radial_depth_profile",
    "read_slot_forces",
    "rotation_angles",
    "save_coefficients",
    "slot_engagement",
    "spindle_power",
]
