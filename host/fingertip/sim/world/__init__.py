"""The simulated physical world the task recipes run in: a four-finger hand and an arm
(:mod:`.hand`), the cup stack (:mod:`.cups`), the two shaken boxes (:mod:`.boxes`), a held
object that slips (:mod:`.slip`), the contact microphones' audio (:mod:`.audio_bus`) and a
simulated teleoperated demonstration (:mod:`.demonstration`).

Everything here implements the robot and sensor interfaces of
:mod:`fingertip.tasks.interfaces`; the recipes in :mod:`fingertip.tasks` never import it.
"""
