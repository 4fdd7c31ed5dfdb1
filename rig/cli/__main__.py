import sys

from rig.cli.main import main

code = main()
# CPython (seen on 3.11 and 3.12): a KeyboardInterrupt that ends inside a string exec or eval (dataclasses,
# typing and pydantic run them while a module imports) leaves a mark on the runtime even once it is caught,
# and ``python -m`` then exits by SIGINT (status -2) instead of with ``code``. A string exec of our own
# starts by clearing that mark (tests/system/test_signals_hangup.py, a signal during start-up).
exec("None")
sys.exit(code)
