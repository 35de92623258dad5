"""Size bounds shared by the assembler and the server, which re-checks every one of them."""

KIB = 1024
MIB = 1024 * KIB

MAX_SMALL_FILE_BYTES = 1 * MIB  # metadata, hyperparameters, params YAML
MAX_EVALUATION_FILE_BYTES = 16 * MIB
MAX_TRAINING_FILE_BYTES = 256 * MIB
MAX_LOG_FILE_BYTES = 256 * MIB  # scanned; a longer log's rest is not read
MAX_LOG_LINE_BYTES = 256 * KIB
MAX_LOG_FILES = 32
MAX_ARCHIVE_MEMBERS = 10_000
MAX_ARCHIVE_UNPACKED_BYTES = 1024 * MIB
MAX_FILES_SCANNED = 10_000
MAX_SNIFFED_FILES = 256  # files no name describes, whose head is read to tell what they hold
SNIFF_BYTES = 64 * KIB
MAX_TRAINING_ENTRIES = 5_000_000  # entries of all training metrics files together
MAX_TRAINING_S = 366 * 24 * 3600  # a training's span, once its timestamps are checked

MAX_RECORD_BYTES = 64 * KIB
TARGET_RECORD_BYTES = 16 * KIB  # a record's training curve is made coarser to fit
MIN_CURVE_POINTS = 25
MAX_EVALUATION_RUNS = 50
MAX_LAPS_PER_RUN = 200
MAX_ACTIONS = 200
MAX_CURVE_POINTS = 200
MAX_SENSORS = 8
MAX_HYPERPARAMETERS = 48
MAX_NAME_CHARS = 64
MAX_TEXT_CHARS = 256
MAX_LAP_MS = 24 * 3600 * 1000
