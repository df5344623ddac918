"""Numba kernels compiled once, then cached on disk for every later process.

A kernel is a plain Python function (its template) that numba compiles with `nogil=True`.
Numba caches only module-level functions whose file it can stamp, and it checks the stamp of
that file alone: a change in a function the kernel calls, in another file, would leave a
stale kernel in its cache. So each kernel is written out as a module of its own,
`<cache>/<sources>/<name>.py`, where `<sources>` is a digest of the sources the kernel
depends on (`dependencies`, lwrl's version among them), numba's, NumPy's and Python's
versions: a change to any of them gives a new directory, compiled afresh, and a change
anywhere else (the command line's help, a study) leaves the kernel where it is.

What a kernel depends on is read from the code, not listed: the modules of its template and
bindings, this module (which writes the kernel's module), lwrl's `__init__` (which holds its
version), and every module they import, transitively, within lwrl and within the packages
the template and bindings come from. A compiled function resolves the names it calls in its module's globals, which its module's
imports bind, so a function the kernel can reach is defined in one of these files. The
imports are read from each file's syntax tree at any depth (a function's local import too),
but not under `if TYPE_CHECKING:`, which never runs; a module imported by name at run time
(`importlib.import_module`, the registries') is not a static import, and a kernel reaches
such a module's functions only through its bindings, which are roots themselves.

The generated module takes the template's module's globals, then the `bindings`
(`{global name: function}`, e.g. the task's `transition` for the compiled loop), so the
template's body resolves its names as it would at home. `helpers` (`{global name:
function}`, functions of the template's module) are written into the module too, compiled
where they are called, so that the bindings reach the functions the template calls as well.
Bindings and helpers are compiled inline into the kernel (`inline_copy`): the compiled
loop's step of a learner and a plant is one function, not calls that copy the batch's
arrays field by field. `kernel(...)` returns a callable that writes, imports and compiles
on its first call.

A kernel made with `runtime=False` is compiled without numba's runtime (`_nrt=False`): it
and every function it calls may allocate nothing and hold no reference counts, so a view of
an array (`arrays.weights[b]`) costs no atomic increment and decrement of the array's
reference count, which numba's runtime spends on every view and call. The compiler refuses
what would need the runtime (an array allocated, one array assigned into another:
`copy_into` does that element by element); the caller passes the memory in.

The cache is `$LWRL_CACHE_DIR`, else `$XDG_CACHE_HOME/lwrl/kernels`, else
`~/.cache/lwrl/kernels`; where it cannot be written, kernels are compiled in memory.

A cache heals: a kernel whose cached files cannot be read (cut short by a full disk, filled
with garbage, unreadable) is compiled again and its files replaced, with one line on
standard error saying so; one whose files cannot be written then says so and runs compiled
in memory. Each file is written under a temporary name and renamed over the
old one (the generated module here; numba's index `.nbi` and data `.nbc` files in
`__pycache__` by numba's own `IndexDataCacheFile._open_for_write`), so a process killed while
writing leaves the old file or the new one, never part of one. The generated module is
compiled from its text, not through a `.pyc`.
"""

import ast
import hashlib
import importlib.util
import inspect
import os
import pathlib
import platform
import sys
import tempfile
import textwrap
import threading
import types

import numba
import numba.core.caching
import numba.extending
import numpy as np

_LOCK = threading.Lock()
_DIGESTS: dict[tuple, str] = {}


def cache_root() -> pathlib.Path:
    """Where compiled kernels are kept (see the module's docstring)."""
    if os.environ.get("LWRL_CACHE_DIR"):
        return pathlib.Path(os.environ["LWRL_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return pathlib.Path(base) / "lwrl" / "kernels"


def _module_file(name: str) -> pathlib.Path | None:
    """The source file of the module `name`, found without importing it (a module already
    imported gives its own); None for a name that is not a module with a `.py` source (a
    function imported from a module, a compiled extension)."""
    module = sys.modules.get(name)
    if module is not None:
        file = getattr(module, "__file__", None)
        return pathlib.Path(file) if file and file.endswith(".py") else None
    parent, _, last = name.rpartition(".")
    if not parent:
        spec = importlib.util.find_spec(name)  # a top-level name: imports nothing
        return pathlib.Path(spec.origin) if spec and (spec.origin or "").endswith(".py") else None
    package = _module_file(parent)
    if package is None or package.name != "__init__.py":
        return None
    for candidate in (package.parent / f"{last}.py", package.parent / last / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _type_checking(test: ast.expr) -> bool:
    """True for the test of `if TYPE_CHECKING:` (or `typing.TYPE_CHECKING`)."""
    return getattr(test, "id", getattr(test, "attr", None)) == "TYPE_CHECKING"


def _import_nodes(nodes):
    """The import statements in `nodes`, at any depth, but those under `if TYPE_CHECKING:`."""
    for node in nodes:
        if isinstance(node, ast.If) and _type_checking(node.test):
            yield from _import_nodes(node.orelse)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        else:
            yield from _import_nodes(ast.iter_child_nodes(node))


def imported_names(name: str, path: pathlib.Path) -> set:
    """The dotted names the module `name` (its source at `path`) imports: `import a.b` gives
    `a.b`; `from a import b` gives `a` and `a.b` (which is a module or a name in `a`)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in _import_nodes([ast.parse(path.read_bytes())]):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        else:
            base = importlib.util.resolve_name("." * node.level + (node.module or ""), package) \
                if node.level else node.module
            found |= {base} | {f"{base}.{alias.name}" for alias in node.names if alias.name != "*"}
    return found


def dependencies(modules) -> dict:
    """`{module name: source file}` of the modules `modules`, this module, lwrl's own
    `__init__` (which holds its version) and every module they import, transitively, within
    lwrl and the top-level packages of `modules` (see the module's docstring)."""
    roots = {name.split(".")[0] for name in modules} | {"lwrl"}
    found: dict = {}
    waiting = [*modules, __name__, "lwrl"]
    while waiting:
        name = waiting.pop()
        if name in found or name.split(".")[0] not in roots:
            continue
        path = _module_file(name)
        if path is None:
            continue
        found[name] = path
        waiting += imported_names(name, path)
    return dict(sorted(found.items()))


def sources_digest(modules=()) -> str:
    """A digest of the sources `modules` depend on (`dependencies`, lwrl's version among
    them) and of the compiler's versions."""
    key = tuple(sorted(modules))
    if key not in _DIGESTS:
        digest = hashlib.sha256()
        for part in (numba.__version__, np.__version__, platform.python_version(), sys.platform):
            digest.update(part.encode())
        for name, path in dependencies(key).items():
            digest.update(name.encode())
            digest.update(path.read_bytes())
        _DIGESTS[key] = digest.hexdigest()[:16]
    return _DIGESTS[key]


def kernel_source(template, bindings: dict, helpers: dict | None = None,
                  runtime: bool = True) -> str:
    """The module text of a kernel: the template's module's globals, the bindings, the
    helpers' sources (compiled where called) under their names, and the template's source
    compiled by numba (cached)."""
    lines = [f'"""Generated by lwrl.kernels from {template.__module__}.{template.__name__}; '
             'do not edit."""', "", "import importlib", "", "import numba", "import numba.extending", "",
             f"globals().update({{name: value for name, value in vars(importlib.import_module("
             f"{template.__module__!r})).items() if not name.startswith('__')}})",
             "from lwrl.kernels import inline_copy"]
    for name, function in sorted(bindings.items()):
        lines.append(f"{name} = inline_copy(importlib.import_module({function.__module__!r})"
                     f".{function.__name__})")
    for name, helper in sorted((helpers or {}).items()):
        lines += ["", "", "@numba.extending.register_jitable(forceinline=True)",
                  textwrap.dedent(inspect.getsource(helper)).rstrip(),
                  f"{name} = {helper.__name__}"]
    source = textwrap.dedent(inspect.getsource(template))
    options = "nogil=True, cache=True" + ("" if runtime else ", _nrt=False")
    return "\n".join(lines) + f"\n\n\n@numba.njit({options})\n" + source


def _write(path: pathlib.Path, text: str) -> bool:
    """Write `text` to `path` whole (a temporary file, then a rename), unless it is there;
    True if a file at `path` held something else or could not be read."""
    try:
        if path.read_text() == text:
            return False
        damaged = True
    except FileNotFoundError:
        damaged = False
    except (OSError, UnicodeDecodeError):
        damaged = True
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".tmp", delete=False) as file:
        file.write(text)
    os.replace(file.name, path)
    return damaged


class _Report:
    """The one line on standard error a kernel's cache may say (later ones are dropped)."""

    def __init__(self, name: str):
        self.name, self.said = name, False

    def __call__(self, what: str) -> None:
        if not self.said:
            self.said = True
            print(f"lwrl: the cached kernel {self.name} {what}", file=sys.stderr, flush=True)


class _HealingCache(numba.core.caching.FunctionCache):
    """numba's cache of a kernel's dispatcher, which compiles again what it cannot read."""

    def __init__(self, py_func, report: _Report):
        super().__init__(py_func)
        self._report = report

    def load_overload(self, sig, target_context):
        try:
            return super().load_overload(sig, target_context)
        except Exception as error:  # cut short, garbage, unreadable: any of pickle's errors
            self._report(f"could not be read ({type(error).__name__}: "
                         f"{' '.join(str(error).split())}); compiling it again")
            try:  # so that the new compilation writes a fresh index, then its data
                os.unlink(self._cache_file._index_path)
            except FileNotFoundError:
                pass
            except OSError as unremovable:
                self._report(f"could not be replaced ({unremovable})")
            return None

    def save_overload(self, sig, data):
        try:
            super().save_overload(sig, data)
        except Exception as error:  # a full disk, an unwritable index: run it from memory
            self._report(f"could not be cached ({type(error).__name__}: "
                         f"{' '.join(str(error).split())}); it runs compiled in memory")


def _load(kernel: "Kernel"):
    """The kernel's numba dispatcher: from its module in the cache, or compiled in memory."""
    path, text, template, bindings = kernel.path, kernel.source, kernel.template, kernel.bindings
    report = _Report(kernel.name)
    try:
        if _write(path, text):
            report(f"module {path} could not be read; written again")
    except OSError:  # no writable cache here: compile in memory
        namespace = {**vars(sys.modules[template.__module__]),
                     **{name: inline_copy(function) for name, function in bindings.items()}}
        for helper_name, helper in kernel.helpers.items():
            namespace[helper_name] = numba.extending.register_jitable(forceinline=True)(
                type(helper)(helper.__code__, namespace, helper.__name__))
        function = type(template)(template.__code__, namespace, template.__name__)
        return numba.njit(nogil=True, _nrt=kernel.runtime)(function)
    module = types.ModuleType(f"lwrl_kernels_{kernel.name}")
    module.__file__ = str(path)
    sys.modules[module.__name__] = module  # numba's cache finds a kernel's module by its name
    exec(compile(text, str(path), "exec"), module.__dict__)
    dispatcher = getattr(module, template.__name__)
    dispatcher._cache = _HealingCache(dispatcher.py_func, report)
    return dispatcher


class Kernel:
    """A kernel compiled on its first call (see the module's docstring)."""

    def __init__(self, name: str, template, bindings: dict | None = None,
                 helpers: dict | None = None, runtime: bool = True):
        self.name = name
        """The kernel's name: its module's file name in the cache."""
        self.runtime = runtime
        """Whether numba's runtime (NRT) is on: arrays may be made inside the kernel."""
        self.template = template
        """The plain Python function compiled, which calls its bindings by their names."""
        self.bindings = dict(bindings or {})
        """Global name -> function the template's body resolves that name to (e.g. the
        task's `transition`), compiled inline."""
        self.helpers = dict(helpers or {})
        """Global name -> function of the template's module, written into the kernel's
        module too and compiled where it is called."""
        self._dispatcher = None

    @property
    def modules(self) -> set:
        """The modules of the template and of the bindings: the roots of its `dependencies`."""
        return {self.template.__module__} | {function.__module__ for function in self.bindings.values()}

    @property
    def path(self) -> pathlib.Path:
        """Where the kernel's module is written, `<cache>/<sources>/<name>.py`: the code
        numba compiles, the template with its bindings in place, for a reader to step
        through."""
        return cache_root() / sources_digest(self.modules) / f"{self.name}.py"

    @property
    def source(self) -> str:
        """The text of the kernel's module (`kernel_source`)."""
        return kernel_source(self.template, self.bindings, self.helpers, self.runtime)

    @property
    def dispatcher(self):
        """The numba dispatcher (its `stats` count cache hits and misses)."""
        if self._dispatcher is None:
            with _LOCK:
                if self._dispatcher is None:
                    self._dispatcher = _load(self)
        return self._dispatcher

    def __call__(self, *args):
        return self.dispatcher(*args)


def inline_copy(function):
    """A copy of the jitable `function` that numba compiles inline wherever it is called
    (LLVM's `alwaysinline`): a kernel's bindings and helpers are inlined into it. A call
    of a compiled function passes every array argument as its pointer, shape and strides,
    and a namedtuple of arrays field by field: the compiled loop's call of a learner's step
    with the batch's arrays copied some 150 words at every step."""
    copy = types.FunctionType(function.__code__, function.__globals__, function.__name__,
                              function.__defaults__, function.__closure__)
    copy.__kwdefaults__ = function.__kwdefaults__
    copy.__doc__ = function.__doc__
    return numba.extending.register_jitable(forceinline=True)(copy)


def kernel(name: str, template, bindings: dict | None = None,
           helpers: dict | None = None, runtime: bool = True) -> Kernel:
    """The kernel `name` (a file name: letters, digits, `_`) compiled from `template` with the
    globals `bindings` replaced and the `helpers` written in under their names; without
    numba's runtime if not `runtime` (see the module's docstring)."""
    if not name.replace("_", "").isalnum():
        raise ValueError(f"kernel name must be letters, digits and _; got {name!r}")
    return Kernel(name, template, bindings, helpers, runtime)


@numba.extending.register_jitable
def copy_into(out, values):
    """`out[:] = values` for 1-D arrays, element by element, as a kernel without numba's
    runtime can (see the module's docstring)."""
    for i in range(values.shape[0]):
        out[i] = values[i]
