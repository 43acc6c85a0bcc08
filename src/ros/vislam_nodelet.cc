#include <nodelet/nodelet.h>
