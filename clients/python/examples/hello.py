"""The smallest Python program: move the rope's head and print where it is.
Usage: hello.py [PREFIX] (default: $TRACTRIX_IOX_PREFIX, else tractrix_)"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from tractrix_client import Client, ServiceError  # noqa: E402

try:
    prefix = sys.argv[1] if len(sys.argv) > 1 else os.environ.get("TRACTRIX_IOX_PREFIX", "tractrix_")
    client = Client(prefix=prefix, wait_for_service=5.0)
    header, elements = client.call("move", client.find_chain("rope"), [(38.0, 5.0, 1.0)])
except (RuntimeError, ServiceError, KeyError, TimeoutError) as e:
    print(e, file=sys.stderr)
    sys.exit(1)
x, y, z = elements[header.n_joints - 1]
print(f"head at {x:g} {y:g} {z:g}, {header.n_joints} joints")
