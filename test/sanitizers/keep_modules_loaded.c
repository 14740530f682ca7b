/* Preloaded by scripts/sanitize: dlclose() keeps every module mapped, so that LeakSanitizer can name the library a
 * leak was allocated in when the report is made at exit. OpenNI2 unloads its drivers (DummyDevice, OniFile) at
 * shutdown; their leaks then showed as "<unknown module>", which no suppression can match. */
#include <dlfcn.h>

int dlclose(void* handle)
{
  (void)handle;
  return 0;
}
