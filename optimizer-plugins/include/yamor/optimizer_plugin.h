/* yamor optimizer plugin ABI.
 *
 * An optimizer plugin is a shared library exporting one C symbol,
 * `yamor_optimizer_plugin`, that returns a pointer to a static
 * YamorOptimizerPlugin. yamor-optimize loads it with dlopen(RTLD_NOW |
 * RTLD_LOCAL), checks `abi_version` and `struct_size`, reads the plugin's
 * description and configuration fields, and calls `run` once per optimizer
 * instance with a YamorOptimizerContext: the problem (named parameters with
 * bounds and start values), the instance's field values, and callbacks that
 * evaluate batches of candidates, report progress, log, say whether a stop
 * was requested and draw seeded random numbers.
 *
 * The plugin maximizes: an evaluation's value is the gait's velocity [m/s]
 * (thesis 6.2.1), or the analytic function's value in tests.
 *
 * C++ plugins normally include yamor/optimizer_plugin.hpp instead, which
 * wraps this ABI in ordinary classes (see optimizer-plugins/powell/).
 *
 * Compatibility: `abi_version` changes only for an incompatible change; a
 * plugin built against ABI version N runs only on a loader of version N.
 * Within a version, structs only grow at their end, and `struct_size` (the
 * writer's sizeof) tells the reader which fields the writer knows:
 *  - a loader accepts a YamorOptimizerPlugin whose `struct_size` is at least
 *    YAMOR_OPTIMIZER_PLUGIN_V1_SIZE (the fields of version 1) and reads only
 *    the fields it knows; a larger struct from a newer header is accepted,
 *    a smaller one is refused, naming both sizes;
 *  - a plugin reads a YamorOptimizerContext field only if it lies within the
 *    context's `struct_size` (never less than YAMOR_OPTIMIZER_CONTEXT_V1_SIZE;
 *    the C++ wrapper refuses a smaller context with YAMOR_FAILED).
 *
 * Thread safety: `run` may be called concurrently from several threads
 * (batch start), each with its own context; a plugin keeps no mutable global
 * state. A context's callbacks may be called only from the thread that is
 * inside `run` with that context.
 */
#ifndef YAMOR_OPTIMIZER_PLUGIN_H_
#define YAMOR_OPTIMIZER_PLUGIN_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The ABI version this header describes. */
#define YAMOR_OPTIMIZER_ABI_VERSION 1u
/** The name of the one symbol a plugin exports. */
#define YAMOR_OPTIMIZER_ENTRY_SYMBOL "yamor_optimizer_plugin"

/** Exports a symbol from a plugin built with -fvisibility=hidden. */
#if defined(__GNUC__)
#define YAMOR_OPTIMIZER_EXPORT __attribute__((visibility("default")))
#else
#define YAMOR_OPTIMIZER_EXPORT
#endif

/** The kind of a configuration field (the thesis's UserConfig fields). */
typedef enum YamorFieldKind {
  YAMOR_FIELD_INTEGER = 0, /**< A whole number in [min, max]. */
  YAMOR_FIELD_REAL = 1,    /**< A finite real in [min, max]. */
  YAMOR_FIELD_BOOLEAN = 2, /**< "true"/"false" (also 1/0, yes/no, on/off). */
  YAMOR_FIELD_FILE = 3,    /**< A path; empty allowed unless min > 0. */
  YAMOR_FIELD_CHOICE = 4,  /**< One of the '|'-separated `choices`. */
  YAMOR_FIELD_TEXT = 5     /**< Free text (e.g. a comma-separated point). */
} YamorFieldKind;

/** A configuration field a plugin declares; values are set with --set. */
typedef struct YamorField {
  const char* name;          /**< [a-z0-9_]+, unique within the plugin. */
  const char* description;   /**< One line for --list-plugins. */
  int32_t kind;              /**< A YamorFieldKind. */
  double min;                /**< Lower bound (INTEGER, REAL). */
  double max;                /**< Upper bound (INTEGER, REAL). */
  const char* default_value; /**< The default, written as on the command line. */
  const char* choices;       /**< CHOICE: "a|b|c"; NULL otherwise. */
} YamorField;

/** One optimized parameter of the problem. */
typedef struct YamorParameter {
  const char* name; /**< E.g. "amplitude.3", "phase.2.5" (DESIGN.md names). */
  double min;       /**< Lower bound, finite. */
  double max;       /**< Upper bound, finite, > min. */
  double start;     /**< The configuration's current value, inside [min, max]. */
} YamorParameter;

/** Results of the context's callbacks. */
typedef enum YamorStatus {
  YAMOR_OK = 0,        /**< Done. */
  YAMOR_STOPPED = 1,   /**< The budget is spent or a stop was requested: return. */
  YAMOR_FAILED = 2,    /**< An error; the message says what (return it). */
  YAMOR_NOT_FOUND = 3  /**< No field with that name. */
} YamorStatus;

/** Log levels for the context's `log`. */
typedef enum YamorLogLevel {
  YAMOR_LOG_DEBUG = 0,
  YAMOR_LOG_INFO = 1,
  YAMOR_LOG_WARNING = 2,
  YAMOR_LOG_ERROR = 3
} YamorLogLevel;

/** What yamor-optimize offers a running plugin instance. */
typedef struct YamorOptimizerContext {
  uint32_t abi_version; /**< YAMOR_OPTIMIZER_ABI_VERSION. */
  uint32_t struct_size; /**< sizeof(YamorOptimizerContext) of the loader. */
  void* host;           /**< Opaque; pass to every callback. */

  size_t parameter_count;            /**< The problem's dimension, >= 1. */
  const YamorParameter* parameters;  /**< parameter_count entries. */
  uint64_t seed;                     /**< This instance's seed. */

  /** A field's value as text (any kind); YAMOR_NOT_FOUND when unknown. The
   *  string stays valid until `run` returns. */
  int32_t (*get_field)(void* host, const char* name, const char** value);

  /** Evaluates `count` candidates, each `parameter_count` values in the
   *  order of `parameters` (row-major in `points`), and writes one value per
   *  candidate to `values` in submission order. Blocks until all are done;
   *  they run in parallel over the host pool. Every point must lie inside
   *  the bounds (YAMOR_FAILED otherwise). YAMOR_STOPPED: the evaluation
   *  budget is spent or a stop was requested; then only the first
   *  `*evaluated` candidates were evaluated (their values are written). */
  int32_t (*evaluate)(void* host, const double* points, size_t count, double* values,
                      size_t* evaluated);

  /** Reports progress in [0, 1] (negative: unknown) and a short status. */
  void (*progress)(void* host, double fraction, const char* status);

  /** Logs one message through yamor-optimize's logger. */
  void (*log)(void* host, int32_t level, const char* message);

  /** Non-zero once the user asked to stop or the budget is spent. */
  int32_t (*stop_requested)(void* host);

  /** A uniformly distributed 64-bit number from this instance's seeded
   *  generator (the only randomness a plugin should use). */
  uint64_t (*random)(void* host);

  /** The last error message of a callback that returned YAMOR_FAILED. */
  const char* (*last_error)(void* host);
} YamorOptimizerContext;

/** What a plugin is: its description, its fields, and its entry point. */
typedef struct YamorOptimizerPlugin {
  uint32_t abi_version; /**< YAMOR_OPTIMIZER_ABI_VERSION of the plugin's build. */
  uint32_t struct_size; /**< sizeof(YamorOptimizerPlugin) of the plugin's build. */
  const char* name;     /**< Short name used by --plugin, [a-z0-9_-]+. */
  const char* version;  /**< The plugin's own version, e.g. "1.0.0". */
  const char* author;   /**< Who wrote it. */
  const char* description; /**< One line for --list-plugins. */
  size_t field_count;      /**< Entries in `fields`. */
  const YamorField* fields; /**< The plugin's configuration fields. */

  /** Runs one optimization to its end (convergence, budget, or stop).
   *  Returns YAMOR_OK or YAMOR_STOPPED; on YAMOR_FAILED writes a
   *  NUL-terminated message of at most `error_size` bytes to `error`. */
  int32_t (*run)(const YamorOptimizerContext* context, char* error, size_t error_size);
} YamorOptimizerPlugin;

/** Size of version 1's YamorOptimizerContext (up to `last_error`): the
 *  smallest context a plugin accepts. */
#define YAMOR_OPTIMIZER_CONTEXT_V1_SIZE                      \
  (offsetof(YamorOptimizerContext, last_error) +             \
   sizeof(((const YamorOptimizerContext*)0)->last_error))

/** Size of version 1's YamorOptimizerPlugin (up to `run`): the smallest
 *  plugin struct a loader accepts. */
#define YAMOR_OPTIMIZER_PLUGIN_V1_SIZE                       \
  (offsetof(YamorOptimizerPlugin, run) + sizeof(((const YamorOptimizerPlugin*)0)->run))

/** The entry point's type: returns the plugin's static description. */
typedef const YamorOptimizerPlugin* (*YamorOptimizerEntry)(void);

#ifdef __cplusplus
}  /* extern "C" */
#endif

#endif  /* YAMOR_OPTIMIZER_PLUGIN_H_ */
