"""The command line: thin commands over the library.

Each command lives in its own module ``aida_kb.cli.<name>`` with two functions,
``register(subparsers)`` and ``run(args) -> int``. Command modules import nothing heavy
at module level (no numpy, scipy or cv2): ``lint`` and ``validate`` must start fast.
"""
