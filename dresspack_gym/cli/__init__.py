"""The ``dresspack`` command line, its argument types and the physics benchmark."""
