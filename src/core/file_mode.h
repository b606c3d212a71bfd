/* file_mode.h — the permissions every output file gets.
 *
 * Outputs are written to a temporary file (mkstemp makes it 0600) and
 * renamed over their path; before the rename each writer gives the file
 * sg_output_file_mode(path): the mode of the file it replaces, else
 * 0666 & ~umask — what open(2) would give a new file, so images, bakes,
 * camera paths and summaries all get the same permissions, as the user's
 * umask says.
 *
 * Thread-safety: reads the umask from /proc/self/status (Linux); where that
 * is missing, from umask(2) itself, setting it back at once (a file created
 * by another thread in between would get mode 0666 & ~022).
 */
#ifndef SG_CORE_FILE_MODE_H
#define SG_CORE_FILE_MODE_H

#include <sys/types.h>

/* The process's umask. */
mode_t sg_umask(void);

/* The mode for an output about to be renamed over path (see above). */
mode_t sg_output_file_mode(const char *path);

#endif
