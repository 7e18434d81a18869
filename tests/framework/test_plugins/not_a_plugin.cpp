// A valid shared library without the plugin entry points.
extern "C" int some_function() { return 42; }
