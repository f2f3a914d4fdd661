"""fingertip: host bridge of the open-source multi-modal tactile fingertip.

Layers (lower never import higher): ``protocol`` (pure codec) <- transport, audio <- device
<- models, events <- tasks; ``sim`` is the virtual fingertip; ``cli`` is the thin command line.
"""
import logging

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())
