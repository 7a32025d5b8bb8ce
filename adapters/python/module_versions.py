"""Prints 'NAME=VERSION' for each Python library an adapter needs and the interpreter imports (configure time)."""
import importlib
import importlib.metadata

for name, module, distribution in (("SCIPY", "scipy.spatial", "scipy"), ("PYKDTREE", "pykdtree.kdtree", "pykdtree"),
                                   ("SKLEARN", "sklearn.neighbors", "scikit-learn")):
    try:
        importlib.import_module(module)
        package = importlib.import_module(module.split(".")[0])
        version = getattr(package, "__version__", None) or importlib.metadata.version(distribution)
    except Exception:  # noqa: BLE001 - any failure means the adapter cannot run here
        continue
    print(f"{name}={version}")
