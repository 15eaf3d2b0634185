"""The goal publisher (``densepack-goal``): the user's goal layout, latched."""
