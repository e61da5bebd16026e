"""The commands, one thin module each (``jaxnav COMMAND``, :mod:`jaxnav.__main__`): each
parses its arguments, calls one function of the layers below and prints; none imports
another or holds logic another command needs."""
