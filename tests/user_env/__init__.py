"""A user's environments, outside the hiddpg package (tests/test_registry.py): ``Slider``
registers itself when imported, ``Ramp`` is registered by whoever names it."""

from user_env.slider import Slider


class Ramp(Slider):
    """The slider under another name, registered by nobody in advance."""

    name = "Ramp"
