"""swimrl: shape-changing microswimmers navigating 2D flows, with TorchRL.

Physics spec: Qiu, Piro, Biferale, Cencini, Mehlig, Gustavsson,
"Adaptive shape control for microswimmer navigation in turbulence".
"""

__version__ = "0.1.0"
