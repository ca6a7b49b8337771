"""The command line's verbs whose engines are slow to import: their arguments live here, light, so that
``bwbench COMMAND --help`` answers at once; the engine is imported only when the command runs."""
