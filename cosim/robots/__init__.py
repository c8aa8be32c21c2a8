"""Robots from other formats: a serial arm's URDF read into a description (:mod:`cosim.robots.urdf`)."""
from .urdf import URDFError, register_urdf, urdf_description

__all__ = ["URDFError", "register_urdf", "urdf_description"]
