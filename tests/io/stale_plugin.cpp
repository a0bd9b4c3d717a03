// A plugin built for another fdv: what load_plugin_api must refuse (format_plugin_test.cpp).
extern "C" __attribute__((visibility("default"))) const char* fdv_plugin_abi() { return "0.0.0/0"; }
extern "C" __attribute__((visibility("default"))) const void* fdv_stale_plugin_api() { return nullptr; }
