"""Manipulation tasks: fixtures, objects and the object configuration ``q_o`` of each."""

from contactmpc.tasks.apple import AppleTask
from contactmpc.tasks.base import ObjectError, ObjectJoint, Task
from contactmpc.tasks.bottle import BottleTask
from contactmpc.tasks.doorknob import DoorknobTask
from contactmpc.tasks.paper_apple import PaperAppleTask
from contactmpc.tasks.paper_bottle import PaperBottleTask
from contactmpc.tasks.paper_doorknob import PaperDoorknobTask
from contactmpc.tasks.paper_stapler import PaperStaplerTask
from contactmpc.tasks.stapler import StaplerTask

__all__ = [
    "AppleTask",
    "BottleTask",
    "DoorknobTask",
    "ObjectError",
    "ObjectJoint",
    "PaperAppleTask",
    "PaperBottleTask",
    "PaperDoorknobTask",
    "PaperStaplerTask",
    "StaplerTask",
    "Task",
]
