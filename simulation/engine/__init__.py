"""The virtual RAVEN-II's engine: the compiled 1 kHz servo loop and the arm that runs it.

``tables`` packs a parameter set into the loop's arrays and names their rows and slots;
``sensors`` (encoders), ``controller`` (``rt_raven.cpp``: coupling, PD, gravity compensation,
DAC, homing) and ``plant`` (motors, cables and links) hold the compiled functions of one servo
tick; ``loop`` runs the ticks and logs them; ``robot`` is the :class:`VirtualRaven` arm and
``scenarios`` the paper's experiments on it. Nothing is imported here: import the module you need.
"""
