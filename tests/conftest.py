import os
import signal
import tempfile

# Several tests send Ctrl-C (SIGINT) to commands and nodes they start. A process
# started where SIGINT is ignored (a background job, nohup, some CI runners) passes
# "ignored" on to every child, which would then never see it; a handler here is
# reset to the default in each child instead.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

# Share compiled programs between tests and their subprocesses: many tests build the
# same tiny trainer, and compiling dominates their time on a 2-core machine.
_cache = os.environ.setdefault(
    "JAX_COMPILATION_CACHE_DIR", os.path.join(tempfile.gettempdir(), "jaxnav-test-jax-cache")
)
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES", "0")
# The reference drivers' rows (jaxnav.experiments.refcache) are kept in a folder of the
# test session's own, never in the user's cache; the commands tests start inherit it.
os.environ["JAXNAV_REFERENCE_CACHE"] = tempfile.mkdtemp(prefix="jaxnav-test-references-")
