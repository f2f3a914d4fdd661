"""The virtual fingertip as a MuJoCo sensor (needs the ``mujoco`` extra).

- :mod:`.attach`: :func:`attach_fingertip` adds a fingertip (base, skin, nail, contact sensors)
  to any body of a user's ``MjSpec``, from the dimensions the CAD uses.
- :mod:`.sensor`: :class:`FingertipSensor` turns that fingertip's contacts, each step, into the
  virtual fingertip's HX711 counts and piezo blocks (fidelity ``wrench``, ``strain``,
  ``full``); :mod:`.contacts` reads MuJoCo's contact sensors, :mod:`.piezo` and
  :mod:`.texture` stream the audio.
- :mod:`.project`: the one module that imports the rest of the project.

See docs/mujoco.md.
"""
from ._require import mujoco as _mujoco

_mujoco()  # one clear line when the extra is missing

from .attach import AttachedFingertip, attach_fingertip, attach_fingertips, geometry  # noqa: E402,E501
from .piezo import Block, PiezoStream  # noqa: E402
from .sensor import FIDELITIES, FingertipSensor, Reading  # noqa: E402

__all__ = ["FIDELITIES", "AttachedFingertip", "Block", "FingertipSensor", "PiezoStream",
           "Reading", "attach_fingertip", "attach_fingertips", "geometry"]
