"""Manipulation tasks: fixtures, objects and the object configuration ``q_o`` of each."""

from contactmpc.tasks.apple import AppleTask
from contactmpc.tasks.base import ObjectError, ObjectJoint, Task
from contactmpc.tasks.bottle import BottleTask
from contactmpc.tasks.doorknob import DoorknobTask
from contactmpc.tasks.stapler import StaplerTask

__all__ = ["AppleTask", "BottleTask", "DoorknobTask", "ObjectError", "ObjectJoint", "StaplerTask", "Task"]
