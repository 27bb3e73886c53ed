/* A shared library without the bubblemesh_plugin_entry symbol. */
int some_function(int x) { return x + 1; }
