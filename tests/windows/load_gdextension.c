/* Loads a Godot extension DLL the way the engine does (LoadLibrary, then the
 * entry symbol) and calls the entry with a get_proc_address that knows no
 * function: the extension must load (its DLL dependencies resolve, its static
 * initialisers run) and refuse cleanly, returning false after asking for its
 * first interface function. Usage: load_gdextension.exe EXTENSION.dll ENTRY_SYMBOL */
#include <stdint.h>
#include <stdio.h>
#include <windows.h>

typedef void (*interface_function)(void);
typedef interface_function (*get_proc_address_fn)(const char *name);
typedef uint8_t (*entry_fn)(get_proc_address_fn get_proc_address, void *library, void *initialization);

static const char *g_first = NULL;
static int g_asked = 0;

static interface_function knows_nothing(const char *name) {
  if (!g_first) g_first = name;
  ++g_asked;
  return NULL;
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: load_gdextension EXTENSION.dll ENTRY_SYMBOL\n");
    return 2;
  }
  HMODULE dll = LoadLibraryA(argv[1]);
  if (!dll) {
    printf("LoadLibrary failed: error %lu\n", (unsigned long)GetLastError());
    return 1;
  }
  entry_fn entry = (entry_fn)(void *)GetProcAddress(dll, argv[2]);
  if (!entry) {
    printf("no entry symbol %s\n", argv[2]);
    return 1;
  }
  /* GDExtensionInitialization: a level, userdata and two callbacks; room to spare. */
  void *initialization[8] = {0};
  int library_token = 0;
  const uint8_t ok = entry(knows_nothing, &library_token, initialization);
  printf("loaded; %s returned %d after asking for '%s'\n", argv[2], (int)ok, g_first ? g_first : "(nothing)");
  FreeLibrary(dll);
  return (ok == 0 && g_asked == 1) ? 0 : 1;
}
