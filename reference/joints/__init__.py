"""Joints and joint formulations (paper §4.2.3)."""

from reference.joints.formulation import Jacobian, JointFormulation, MasterSlave
from reference.joints.joint import Joint, joint_frame

__all__ = ["Jacobian", "Joint", "JointFormulation", "MasterSlave", "joint_frame"]
